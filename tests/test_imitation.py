"""The start of a PPO run from imitation of a classic strategy: the demonstrations come from the training env, the
fit brings the policy's mean to the teacher's actions (beyond the bound where the teacher sits at it), and the
settings are checked before any work."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.training.config import build_config, load_run_config
from hev_thermal_env.training.envs import env_kwargs
from hev_thermal_env.training.fit import fit_policy_mean, fit_weights
from hev_thermal_env.training.imitation import (
    INIT_DEFAULTS,
    InitConfig,
    demonstrations,
    teacher_of,
)
from tests.support.training import check_init

ROOT = Path(__file__).resolve().parents[1]


ENV = {"cycles": ["random_bus"], "scenario": "random_service", "random_start": True, "preview_s": 10,
       "preview_step_s": 2, "thermal": True, "reward": {}}


def test_the_teachers_options_reach_its_demonstrations():
    """``init.teacher_options`` build the teacher: the shipped file keeps the physics version's heat prices and
    firms the SOC feedback; ``x_price: margin`` lets ``ecms_thermal`` derate a cool motor where the fixed price never
    does, and gives other actions from the same episodes."""
    assert build_config("ppo")["init"]["teacher_options"] == {"k_soc": 1.5}
    teachers = {p: teacher_of({"imitate": "ecms_thermal", "teacher_options": {"x_price": p}})
                for p in ("fixed", "margin")}
    runs = {p: demonstrations(env_kwargs(ENV), t, 2, seed=5) for p, t in teachers.items()}
    np.testing.assert_array_equal(runs["fixed"][0], demonstrations(env_kwargs(ENV), "ecms_thermal", 2, seed=5)[0])
    assert not np.array_equal(runs["fixed"][1], runs["margin"][1])


def test_demonstrations_are_the_teachers_own_run_on_fresh_training_cycles():
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 2, seed=5)
    assert obs.shape == (2 * 1300, 21) and obs.dtype == np.float32 and actions.shape == (2 * 1300,)
    assert np.all(np.abs(actions) <= 1.0) and np.mean(actions == 1.0) > 0.05  # the teacher does stop the engine
    again, same = demonstrations(env_kwargs(ENV), "ecms_thermal", 2, seed=5)
    np.testing.assert_array_equal(obs, again)
    np.testing.assert_array_equal(actions, same)
    other, _ = demonstrations(env_kwargs(ENV), "ecms_thermal", 2, seed=6)
    assert not np.array_equal(obs[:, 0], other[:, 0])  # another seed, other cycles
    # the episodes are the env's: the first observation is the env's reset observation for that seed
    first, _ = HevThermalEnv(**{**env_kwargs(ENV), "random_start": False}).reset(seed=5 * 1_000_003)
    np.testing.assert_array_equal(obs[0], first)


def test_noisy_demonstrations_drive_off_the_teachers_path_and_keep_its_labels(monkeypatch):
    """``init.noise``: the env is driven by the teacher's action plus noise, each state is labelled with the teacher's
    own action there (what the teacher returned, within the bounds, not what drove the env), reproducibly."""
    import hev_thermal_env.training.imitation as imitation

    said: list[float] = []
    real = imitation.get_strategy

    def recording(name):
        strategy = real(name)
        act = strategy.act
        strategy.act = lambda obs, info: said.append(float(np.asarray(act(obs, info)).reshape(-1)[0])) or said[-1]
        return strategy

    monkeypatch.setattr(imitation, "get_strategy", recording)
    clean, clean_actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=3)
    said.clear()
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=3, noise=0.3)
    np.testing.assert_array_equal(actions, np.asarray(said, dtype=np.float32))
    assert np.all(np.abs(actions) <= 1.0)
    np.testing.assert_array_equal(obs[0], clean[0])  # the same episode, from the same reset
    assert np.mean(np.any(obs != clean, axis=1)) > 0.5  # and off the teacher's own path from then on
    again, same = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=3, noise=0.3)
    np.testing.assert_array_equal(obs, again)
    np.testing.assert_array_equal(actions, same)


@pytest.mark.full
def test_fit_brings_the_policy_mean_to_the_teacher_and_beyond_the_bound_where_it_stops_the_engine():
    from stable_baselines3 import PPO

    env = HevThermalEnv(**env_kwargs(ENV))
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 2, seed=1)
    x = ((obs - obs.mean(0)) / (obs.std(0) + 1e-6)).astype(np.float32)
    at_bound = actions >= 1.0
    reached = {}
    for beyond in (0.25, 0.0):
        model = PPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs={"net_arch": [64, 64]})
        history = fit_policy_mean(model.policy, x, actions, epochs=60, beyond_bound=beyond, high=1.0, seed=0)
        assert history[-1] < 0.7 * history[0]
        act = np.clip(model.predict(x, deterministic=True)[0][:, 0], -1.0, 1.0)
        assert act[at_bound].mean() > act[~at_bound].mean() + 0.3  # higher where the teacher stops the engine
        reached[beyond] = (np.mean(act[at_bound] >= 1.0), np.mean(act[~at_bound] >= 1.0))
    assert reached[0.25][0] > 0.02 and reached[0.25][1] < 0.01  # the bound, where the teacher is at it only
    # fitted beyond the bound: the clipped mean gets there (the teacher also takes all the regeneration, u = 1, at
    # every braking step, which a plain fit reaches more easily: 0.56 against 0.28 of the steps at the bound)
    assert reached[0.25][0] > 1.5 * reached[0.0][0]


def test_init_section_is_a_typed_record_with_a_yaml_round_trip(tmp_path):
    """The shipped policy's ``init`` section loads unchanged and writes back the same; errors name the file."""
    import yaml

    shipped = yaml.safe_load((ROOT / "agents" / "policies" / "ppo_default" / "config.yaml").read_text())["init"]
    init = InitConfig.from_dict(shipped).for_run("ppo")
    assert init.to_dict() == shipped and InitConfig.from_yaml(_write(tmp_path / "init.yaml", init.to_yaml())) == init
    with pytest.raises(ValueError, match=r"bad.yaml: init.episodes must be a whole number of at least 1, got 0"):
        InitConfig.from_yaml(_write(tmp_path / "bad.yaml", "episodes: 0\n"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        init.episodes = 3


def _write(path, text):
    path.write_text(text)
    return path


def test_init_settings_are_checked_in_one_line():
    assert check_init({}, "ppo") == INIT_DEFAULTS and INIT_DEFAULTS["imitate"] is None
    assert build_config("ppo")["init"]["imitate"] == "ecms_thermal"  # the shipped hyperparameters imitate ECMS
    assert build_config("ppo", overrides={"init.imitate": None})["init"]["imitate"] is None
    for bad, match in (({"init.imitate": "dp_thermal"}, "step-by-step classic"), ({"init.imitate": "ppo"}, "classic"),
                       ({"init.episodes": 0}, "init.episodes"), ({"init.epochs": 1.5}, "init.epochs"),
                       ({"init.beyond_bound": 2}, "beyond_bound"), ({"init.teacher": "ecms"}, "unknown init"),
                       ({"init.noise": 1.5}, "init.noise"), ({"init.noise": True}, "init.noise"),
                       ({"init.freeze_obs_stats": "yes"}, "true, false or a list"),
                       ({"init.freeze_obs_stats": ["motor_temp"]}, r"unknown observation\(s\) \['motor_temp'\]"),
                       ({"init.imitate": None, "init.freeze_obs_stats": True}, "set init.imitate"),
                       ({"init.refit_batches": -1}, "init.refit_batches"), ({"init.refit_lr": 0}, "init.refit_lr"),
                       ({"init.refit_lr": "fast"}, "init.refit_lr"), ({"init.dagger_every": 1.5}, "dagger_every"),
                       ({"init.refit_decay": "yes"}, "init.refit_decay"),
                       ({"init.heat_weight": -1}, "init.heat_weight"), ({"init.heat_weight": True}, "heat_weight"),
                       ({"init.heat_weight_above_x": -0.5}, "heat_weight_above_x"),
                       ({"init.dagger_every": 1000, "init.refit_batches": 0}, "set init.refit_batches"),
                       ({"init.teacher_options": "margin"}, "init.teacher_options must be a mapping"),
                       ({"init.teacher_options.x_price": "cheap"}, r"init.teacher_options: .*x_price 'cheap'"),
                       ({"init.teacher_options.w_heat": 1.0}, "init.teacher_options: .*w_heat")):
        with pytest.raises(ValueError, match=match):
            build_config("ppo", overrides=bad)
    # another teacher than the file's: its options go with null (the file's are ecms_thermal's)
    with pytest.raises(ValueError, match=r"unknown option.*'k_soc'.*init.teacher_options=null"):
        build_config("ppo", overrides={"init.imitate": "rule", "init.cost_weight": 0.0})
    assert build_config("ppo", overrides={"init.imitate": "rule", "init.cost_weight": 0.0,
                                          "init.teacher_options": None})["init"]["teacher_options"] == {}
    assert build_config("ppo", overrides={"init.imitate": "ecms"})["init"]["teacher_options"] == {"k_soc": 1.5}
    with pytest.raises(ValueError, match="PPO runs only"):
        build_config("sac", overrides={"init.imitate": "ecms"})
    frozen = build_config("ppo", overrides={"init.freeze_obs_stats": ["motor_temp_c", "heat_x"]})
    assert frozen["init"]["freeze_obs_stats"] == ["motor_temp_c", "heat_x"]


def test_heat_weight_fits_the_approach_to_derating_closer():
    """``init.heat_weight``: states whose heat-index integrator lies above ecms_thermal's threshold count more in the
    fit. On demonstrations where they are 5 % and the teacher acts otherwise there, a fit with the weight brings a small
    network closer to the teacher on them than the plain fit, at a smaller cost elsewhere; weight 0 is the plain
    fit (no weights at all, so a run without it is unchanged)."""
    from stable_baselines3 import PPO

    rng = np.random.default_rng(3)
    n = 6000
    obs = rng.normal(size=(n, 21)).astype(np.float32)
    near = rng.random(n) < 0.05
    obs[:, 9] = np.where(near, rng.uniform(-0.049, 0.2, n), rng.uniform(-0.3, -0.05, n))  # x: above -0.05, or not
    actions = np.where(near, -0.5, 0.4 * np.tanh(obs[:, 0])).astype(np.float32)  # the teacher spares a hot motor
    x = ((obs - obs.mean(0)) / obs.std(0)).astype(np.float32)
    assert fit_weights(obs, 0.0, -0.05) is None
    weights = fit_weights(obs, 20.0, -0.05)
    assert np.array_equal(weights > 1.0, near) and set(np.unique(weights)) == {1.0, 21.0}
    assert np.array_equal(fit_weights(obs, 20.0, 0.0) > 1.0, obs[:, 9] > 0.0)
    env = HevThermalEnv(**env_kwargs(ENV))
    errors = {}
    for w in (None, weights):
        model = PPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs={"net_arch": [16]})
        fit_policy_mean(model.policy, x, actions, epochs=10, beyond_bound=0.25, high=1.0, seed=0, weights=w)
        err = (model.predict(x, deterministic=True)[0][:, 0] - actions) ** 2
        errors["plain" if w is None else "weighted"] = (err[near].mean(), err[~near].mean())
    (near_plain, far_plain), (near_weighted, far_weighted) = errors["plain"], errors["weighted"]
    assert near_weighted < 0.5 * near_plain
    assert far_weighted - far_plain < near_plain - near_weighted


@pytest.mark.parametrize("freeze", [True, False, ["motor_temp_c", "heat_x"]])
def test_frozen_observation_statistics_stay_the_demonstrations(tmp_path, freeze):
    """With ``init.freeze_obs_stats`` the saved statistics of the frozen entries are the demonstrations' after PPO has
    run; the others move with the states PPO visits."""
    import pickle

    import train
    from hev_thermal_env.envs.spaces import observation_names
    from hev_thermal_env.training.imitation import FrozenRunningMeanStd

    out = tmp_path / "run"
    setting = "[" + ",".join(freeze) + "]" if isinstance(freeze, list) else str(freeze).lower()
    hp = ["n_steps=64", "batch_size=128", "n_epochs=1", "policy_kwargs.net_arch=[16,16]", "init.episodes=1",
          "init.epochs=1", f"init.freeze_obs_stats={setting}"]
    code = train.main(["--algo", "ppo", "--cycles", "random_bus", "--scenario", "random_service", "--timesteps", "512",
                       "--n-envs", "2", "--seed", "2", "--out", str(out), "--no-progress", "--quiet", "--eval-cycles",
                       "--hp", *hp])
    assert code == 0
    with open(out / "vecnormalize.pkl", "rb") as fh:
        rms = pickle.load(fh).obs_rms
    assert isinstance(rms, FrozenRunningMeanStd) is (freeze is not False)
    run_env = load_run_config(out)["env"]  # ppo.yaml's env section with the test's cycles: the run's demonstrations
    obs, _ = demonstrations(env_kwargs(run_env), teacher_of(build_config("ppo")["init"]), 1, seed=2)
    demo_mean = obs.mean(axis=0, dtype=np.float64)
    names = np.asarray(observation_names(10, 2))
    varied = obs.var(axis=0, dtype=np.float64) > 1e-12
    frozen = varied if freeze is True else np.isin(names, freeze or [])
    if freeze is True:
        assert not varied[list(names).index("heat_index")] and varied.sum() >= 15  # the teacher never derates
    np.testing.assert_allclose(rms.mean[frozen], demo_mean[frozen], rtol=1e-12)
    moved = ~np.isclose(rms.mean, demo_mean, rtol=1e-9)
    assert not moved[frozen].any() and moved[~frozen].sum() >= (1 if freeze is True else 10)


def _refit_setup(batches=8, dagger_every=0, **init_settings):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from hev_thermal_env.training.imitation import DemonstrationRefit

    venv = VecNormalize(DummyVecEnv([lambda: HevThermalEnv(**env_kwargs(ENV))]), norm_reward=False)
    obs, actions = demonstrations(env_kwargs(ENV), "ecms_thermal", 1, seed=4)
    venv.obs_rms.mean, venv.obs_rms.var = obs.mean(0).astype(np.float64), obs.var(0).astype(np.float64)
    model = PPO("MlpPolicy", venv, seed=0, device="cpu", n_steps=64, policy_kwargs={"net_arch": [32, 32]})
    fit_policy_mean(model.policy, venv.normalize_obs(obs), actions, epochs=150, beyond_bound=0.25, high=1.0, seed=0)
    init = {**INIT_DEFAULTS, "imitate": "ecms_thermal", "refit_batches": batches, "dagger_every": dagger_every,
            "dagger_episodes": 1, **init_settings}
    refit = DemonstrationRefit(obs, actions, init=init, env_kwargs=env_kwargs(ENV), high=1.0, seed=4)
    refit.init_callback(model)
    return venv, model, refit, obs, actions


def _mse(model, x, actions):
    import torch

    with torch.no_grad():
        mean = model.policy.get_distribution(torch.as_tensor(x)).distribution.mean[:, 0].numpy()
    return float(np.mean((mean - np.where(actions >= 1.0, 1.25, actions)) ** 2))


def test_refit_follows_the_statistics_as_they_drift():
    """``init.refit_batches``: a drift of the observation statistics moves the fitted policy off the teacher (what
    loses ``ecms_thermal``'s protection, docs/training.md); refitting the demonstrations under the drifted statistics
    brings it back, and without the drift the refit keeps the fit where it was."""
    venv, model, refit, obs, actions = _refit_setup()
    fitted = _mse(model, venv.normalize_obs(obs), actions)
    for _ in range(5):
        refit.on_rollout_end()
    kept = _mse(model, venv.normalize_obs(obs), actions)
    assert kept < 1.2 * fitted
    venv.obs_rms.mean = venv.obs_rms.mean + 1.5 * np.sqrt(venv.obs_rms.var)  # every input seen 1.5 spreads lower
    venv.obs_rms.var = venv.obs_rms.var * 4.0
    drifted = _mse(model, venv.normalize_obs(obs), actions)
    assert drifted > 2.0 * fitted
    for _ in range(15):
        refit.on_rollout_end()
    refitted = _mse(model, venv.normalize_obs(obs), actions)
    assert refitted < 0.5 * drifted and len(refit.mse) == 20
    summary = refit.summary()
    assert summary["refits"] == 20 and summary["dagger_rounds"] == 0 and summary["demonstration_steps"] == len(obs)


def test_dagger_adds_the_students_states_labelled_by_the_teacher(monkeypatch):
    """``init.dagger_every``: once that many env-steps are done the policy drives fresh episodes and the teacher's
    actions on the states it visits join the demonstrations; the states are the student's, not the teacher's path."""
    import hev_thermal_env.training.imitation as imitation

    venv, model, refit, obs, actions = _refit_setup(batches=1, dagger_every=100)
    driven: list[np.ndarray] = []
    real = imitation.demonstrations

    def recording(*args, drive=None, **kw):
        return real(*args, drive=lambda o: driven.append(drive(o)) or driven[-1], **kw)

    monkeypatch.setattr(imitation, "demonstrations", recording)
    model.num_timesteps = 50
    refit.on_rollout_end()
    assert refit.rounds == 0 and len(refit.obs) == len(obs)
    model.num_timesteps = 100
    refit.on_rollout_end()
    assert refit.rounds == 1 and len(refit.obs) == len(obs) + len(driven) and len(driven) > 1000
    new_obs, new_actions = refit.obs[len(obs):], refit.actions[len(obs):]
    teacher_obs, teacher_actions = real(env_kwargs(ENV), "ecms_thermal", 1, seed=4 + 1_000)
    np.testing.assert_array_equal(new_obs[0], teacher_obs[0])  # the same fresh episode, from the same reset
    assert np.mean(np.any(new_obs[:len(teacher_obs)] != teacher_obs[:len(new_obs)], axis=1)) > 0.5  # student's path
    student = np.asarray(driven).reshape(-1)
    assert np.mean(np.abs(student[:len(new_actions)] - new_actions[:len(student)]) > 1e-3) > 0.2  # labels: teacher's
    assert np.all(np.abs(new_actions) <= 1.0)
    assert refit.weight is None  # no heat weight: the plain fit, before and after a round


def test_the_refit_weights_every_demonstration_state_also_after_a_dagger_round(monkeypatch):
    """``init.heat_weight`` reaches the refit: its weights follow the demonstrations, also when a DAgger round adds the
    student's states (built from their own heat-index integrator), and the loss uses them."""
    import hev_thermal_env.training.imitation as imitation

    venv, model, refit, obs, actions = _refit_setup(batches=1, dagger_every=100, heat_weight=20.0,
                                                    heat_weight_above_x=-0.2)
    np.testing.assert_array_equal(refit.weight > 1.0, obs[:, 9] > -0.2)
    student_obs = obs[:300].copy()
    student_obs[:, 9] = np.linspace(-0.3, 0.3, 300)  # half of the student's states near derating
    monkeypatch.setattr(imitation, "demonstrations", lambda *a, **k: (student_obs, actions[:300]))
    model.num_timesteps = 100
    refit.on_rollout_end()
    assert refit.rounds == 1 and len(refit.weight) == len(refit.obs) == len(obs) + 300
    np.testing.assert_array_equal(refit.weight[len(obs):] > 1.0, student_obs[:, 9] > -0.2)
    assert set(np.unique(refit.weight)) <= {1.0, 21.0}
    assert imitation.heat_weighting({"heat_weight": 20}) == (20.0, 0.0)  # the threshold's default: derating


def test_a_run_with_refit_and_dagger_records_them_and_a_resumed_run_drives_its_demonstrations_again(tmp_path):
    """``train.py`` with ``init.refit_batches`` and ``init.dagger_every`` on a tiny budget: the run records the refits
    and DAgger rounds; a resumed run gets its first demonstrations again (the same states and labels) and continues
    DAgger from the next round."""
    import yaml

    import train
    from hev_thermal_env.training.imitation import resumed_refit

    out = tmp_path / "run"
    hp = ["n_steps=64", "batch_size=128", "n_epochs=1", "policy_kwargs.net_arch=[16,16]", "init.episodes=1",
          "init.epochs=1", "init.refit_batches=2", "init.dagger_every=256", "init.dagger_episodes=1"]
    code = train.main(["--algo", "ppo", "--cycles", "random_bus", "--scenario", "random_service", "--timesteps", "512",
                       "--n-envs", "2", "--seed", "2", "--out", str(out), "--no-progress", "--quiet", "--eval-cycles",
                       "--hp", *hp])
    assert code == 0
    imitation = yaml.safe_load((out / "config.yaml").read_text())["result"]["imitation"]
    refit = imitation["refit"]
    assert refit["refits"] == 4 and refit["dagger_rounds"] == 2 and refit["batches_per_rollout"] == 2
    assert refit["demonstration_steps"] == 3 * 1300
    # the default charges the teacher's own cost: the fitted policy's excess by it is recorded, and is small
    assert 0.0 < imitation["cost_excess_g_per_step"] < 1.0

    _, model, _, obs, actions = _refit_setup()
    model.num_timesteps = 700
    init = {**INIT_DEFAULTS, "imitate": "ecms_thermal", "episodes": 1, "refit_batches": 2, "dagger_every": 256}
    again = resumed_refit(model, env_kwargs(ENV), init, seed=4)
    np.testing.assert_array_equal(again.obs, obs)
    np.testing.assert_array_equal(again.actions, actions)
    assert again.rounds == 2
    assert resumed_refit(model, env_kwargs(ENV), {**init, "refit_batches": 0}, seed=4) is None



def test_the_refit_rate_follows_the_ppo_schedule_when_asked():
    """``init.refit_decay``: the refit's learning rate decays with PPO's (``learning_rate: lin_...``), so late in a
    run the refit no more than PPO moves the policy; without it the rate stays ``init.refit_lr``."""
    _, model, refit, _, _ = _refit_setup(batches=1)
    model.lr_schedule = lambda progress: 3e-5 * progress
    model._current_progress_remaining = 0.5
    refit.on_rollout_end()
    assert refit.opt.param_groups[0]["lr"] == pytest.approx(1e-4)
    refit.decay = True
    for progress, expected in ((1.0, 1e-4), (0.5, 5e-5), (0.0, 0.0)):
        model._current_progress_remaining = progress
        refit.on_rollout_end()
        assert refit.opt.param_groups[0]["lr"] == pytest.approx(expected)
