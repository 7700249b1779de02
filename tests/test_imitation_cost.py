"""``init.cost_weight``: the imitation also charges the student's action the teacher's own cost of it. The teacher's
cost curve is what it minimised, the charge reads it between candidates, and a fit that pays it acts cheaper by the
teacher's measure than one that only matches the action."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.training.envs import env_kwargs
from hev_thermal_env.training.fit import cost_excess_g, fit_loss, fit_policy_mean, mean_cost_excess_g
from hev_thermal_env.training.imitation import INIT_DEFAULTS, demonstrations
from tests.support.training import check_init

ENV = {"cycles": ["random_bus"], "scenario": "random_service", "random_start": True, "preview_s": 10,
       "preview_step_s": 2, "thermal": True, "reward": {}}


def test_the_charge_reads_the_curve_at_the_candidates_and_linearly_between_them():
    curves = torch.tensor([[4.0, 2.0, 0.0, 1.0, 3.0]] * 6)  # candidates at u = -1, -0.5, 0, 0.5, 1
    u = torch.tensor([-1.0, -0.75, 0.0, 0.25, 1.0, 1.25], requires_grad=True)
    charge = cost_excess_g(u, curves)
    np.testing.assert_allclose(charge.detach().numpy(), [4.0, 3.0, 0.0, 0.5, 3.0, 3.0], atol=1e-6)
    charge.sum().backward()
    # the slope of the curve where the action lies: towards the cheapest candidate the charge falls; beyond the bound
    # (where the env clips) the action costs what the bound costs, with no pull
    np.testing.assert_allclose(u.grad.numpy(), [-4.0, -4.0, 2.0, 2.0, 4.0, 0.0], atol=1e-6)


def test_the_loss_without_a_cost_weight_is_the_squared_error_and_with_one_adds_the_charge():
    mean, target = torch.tensor([0.0, 0.5]), torch.tensor([0.5, 0.5])
    curves = np.array([[2.0, 0.0, 2.0], [0.0, 1.0, 2.0]], dtype=np.float32)
    assert float(fit_loss(mean, target, None)) == pytest.approx(0.125)
    assert float(fit_loss(mean, target, None, curves, 0.0)) == pytest.approx(0.125)
    # charges: u = 0 on the first curve costs 0, u = 0.5 on the second 1.5; mean 0.75
    assert float(fit_loss(mean, target, None, curves, 2.0)) == pytest.approx(0.125 + 2.0 * 0.75)
    with pytest.raises(ValueError, match="cost curves"):
        fit_loss(mean, target, None, None, 1.0)


def test_the_teachers_curve_is_its_own_cost_and_its_action_the_cheapest():
    """``ecms_thermal`` records each step's candidate costs above the cheapest: zero at its action, never negative,
    zero everywhere while standing; its actions are those it takes without the curves being asked for."""
    costs: list[np.ndarray] = []
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=4, costs=costs)
    plain_obs, plain_actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=4)
    np.testing.assert_array_equal(actions, plain_actions)
    curves = np.stack(costs)
    assert curves.shape == (len(actions), 41) and curves.dtype == np.float32
    assert np.all(curves >= 0.0) and np.all(curves.min(axis=1) == 0.0)
    grid = np.linspace(-1.0, 1.0, 41)
    at_action = curves[np.arange(len(actions)), np.abs(grid[None, :] - actions[:, None]).argmin(axis=1)]
    assert np.all(at_action <= 1e-3 + 1e-3 * curves.max(axis=1))  # the chosen candidate (ties: the smallest share)
    moving = curves.max(axis=1) > 0.0
    assert 0.3 < moving.mean() < 1.0  # standing steps: a flat curve
    # the charge of the teacher's own actions is nil
    charge = cost_excess_g(torch.as_tensor(actions), torch.as_tensor(curves)).numpy()
    assert np.all(charge <= 1e-3 + 1e-3 * curves.max(axis=1))


def test_a_fit_that_pays_the_teachers_cost_acts_cheaper_by_it():
    """On physics v1, where only u = 1 stops the engine and u just below it burns idle fuel: the teacher's cost tells
    the fit where an error is dear. (On v2 the engine-off band removed that cliff, and the term no longer pays on
    this one-episode fit: 0.0593 against 0.0547 g per step.)"""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    kwargs = {**env_kwargs(ENV), "physics": 1}
    costs: list[np.ndarray] = []
    obs, actions = demonstrations(kwargs, "ecms_thermal", 1, seed=4, costs=costs)
    curves = np.stack(costs)
    venv = VecNormalize(DummyVecEnv([lambda: HevThermalEnv(**kwargs)]), norm_reward=False)
    venv.obs_rms.mean, venv.obs_rms.var = obs.mean(0).astype(np.float64), obs.var(0).astype(np.float64)
    x = venv.normalize_obs(obs)
    excess = {}
    for weight in (0.0, 5.0):
        model = PPO("MlpPolicy", venv, seed=0, device="cpu", n_steps=64, policy_kwargs={"net_arch": [32, 32]})
        fit_policy_mean(model.policy, x, actions, epochs=60, beyond_bound=0.25, high=1.0, seed=0, curves=curves,
                        cost_weight=weight)
        excess[weight] = mean_cost_excess_g(model.policy, x, curves)
    assert 0.0 < excess[5.0] < 0.8 * excess[0.0]
    with pytest.raises(ValueError, match="cost curves for"):
        fit_policy_mean(model.policy, x, actions, epochs=1, beyond_bound=0.25, high=1.0, seed=0, curves=curves[:-1],
                        cost_weight=1.0)


def test_the_cost_weight_is_checked_and_needs_a_teacher_that_prices_its_candidates():
    base = {"imitate": "ecms_thermal"}
    assert check_init(base, "ppo")["cost_weight"] == INIT_DEFAULTS["cost_weight"] == 0.0
    with pytest.raises(ValueError, match="init.cost_weight must be a number in"):
        check_init({**base, "cost_weight": -1}, "ppo")
    with pytest.raises(ValueError, match="'rule' does not price its candidate actions"):
        check_init({"imitate": "rule", "cost_weight": 1.0}, "ppo")  # before any work
    assert check_init({"imitate": "rule"}, "ppo")["cost_weight"] == 0.0
    costs: list[np.ndarray] = []
    with pytest.raises(ValueError, match="'rule' does not price its candidate actions"):
        demonstrations(env_kwargs(ENV), get_strategy("rule"), 1, seed=4, costs=costs)


def test_the_refit_charges_the_curves_and_a_dagger_round_adds_the_teachers_curves_of_the_students_states():
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from hev_thermal_env.training.imitation import DemonstrationRefit

    costs: list[np.ndarray] = []
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=4, costs=costs)
    venv = VecNormalize(DummyVecEnv([lambda: HevThermalEnv(**env_kwargs(ENV))]), norm_reward=False)
    venv.obs_rms.mean, venv.obs_rms.var = obs.mean(0).astype(np.float64), obs.var(0).astype(np.float64)
    model = PPO("MlpPolicy", venv, seed=0, device="cpu", n_steps=64, policy_kwargs={"net_arch": [32, 32]})
    init = {**INIT_DEFAULTS, "imitate": "ecms_thermal", "refit_batches": 20, "dagger_every": 100,
            "dagger_episodes": 1, "cost_weight": 5.0}
    refit = DemonstrationRefit(obs, actions, init=init, env_kwargs=env_kwargs(ENV), high=1.0, seed=4,
                               curves=np.stack(costs))
    refit.init_callback(model)
    x = venv.normalize_obs(obs)
    before = mean_cost_excess_g(model.policy, x, refit.curves[:len(obs)])
    model.num_timesteps = 100
    refit.on_rollout_end()
    assert refit.rounds == 1 and len(refit.curves) == len(refit.obs) == len(refit.actions) > len(obs)
    assert np.all(refit.curves.min(axis=1) == 0.0)
    for _ in range(10):
        refit.on_rollout_end()
    assert mean_cost_excess_g(model.policy, x, refit.curves[:len(obs)]) < 0.8 * before


def test_a_resumed_run_gets_the_teachers_curves_of_its_first_demonstrations_again():
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from hev_thermal_env.training.imitation import resumed_refit

    costs: list[np.ndarray] = []
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=4, costs=costs)
    venv = VecNormalize(DummyVecEnv([lambda: HevThermalEnv(**env_kwargs(ENV))]), norm_reward=False)
    model = PPO("MlpPolicy", venv, seed=0, device="cpu", n_steps=64, policy_kwargs={"net_arch": [16, 16]})
    init = {**INIT_DEFAULTS, "imitate": "ecms_thermal", "episodes": 1, "refit_batches": 2, "cost_weight": 1.0}
    again = resumed_refit(model, env_kwargs(ENV), init, seed=4)
    np.testing.assert_array_equal(again.obs, obs)
    np.testing.assert_array_equal(again.curves, np.stack(costs))
    assert again.cost_weight == 1.0
    plain = resumed_refit(model, env_kwargs(ENV), {**init, "cost_weight": 0.0}, seed=4)
    assert plain.curves is None and plain.cost_weight == 0.0
