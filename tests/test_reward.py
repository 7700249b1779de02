"""The one compiled reward against its documented formula, computed independently here in numpy."""

from __future__ import annotations

import numpy as np
import pytest

from hev_thermal_env.envs.reward import REWARD_TERMS, RewardParams, reward_terms, stage_cost_g
from hev_thermal_env.physics import core as C
from hev_thermal_env.prices import Prices

LHV = 43000.0


def _batch(n=400, seed=1):
    rng = np.random.default_rng(seed)
    out = rng.normal(size=(n, C.N_OUT)) * 3000.0
    st = rng.normal(size=(n, C.N_STATE))
    st[:, C.TEMP_C] = rng.uniform(20.0, 80.0, n)
    st[:, C.CUTOFF] = rng.integers(0, 2, n)
    return out, st


def _documented(rp: RewardParams, out, st, target, dt):
    eta_e, eta_c, eta_d, eta_l = 0.36, 0.90, 0.90, 0.93  # the documented default efficiencies
    batt_g = out[:, C.BATT_CHEM] * dt / (LHV * eta_e * eta_c)
    miss_g = out[:, C.MISSED_J] / (LHV * eta_e * eta_c * eta_d * eta_l)
    dev = ((st[:, C.SOC] - target) / rp.soc_deviation_scale) ** 2
    over = np.maximum(st[:, C.TEMP_C] - rp.overheat_soft_limit_c, 0.0)
    return {
        "reward_fuel": -rp.fuel_weight * out[:, C.FUEL_G],
        "reward_miss": -rp.miss_weight * miss_g,
        "reward_soc": -rp.soc_energy_weight * batt_g - rp.soc_deviation_weight * dev,
        "reward_overheat": -rp.overheat_temp_weight * over ** 2 - rp.cutoff_weight * st[:, C.CUTOFF]
        - rp.derate_weight * np.clip(st[:, C.HEAT_X], 0.0, 1.0),
    }


@pytest.mark.parametrize("rp", [RewardParams(), RewardParams(derate_weight=0.7, soc_deviation_weight=0.3,
                                                             soc_deviation_scale=0.05, miss_weight=2.0)])
def test_reward_terms_follow_the_documented_formula(rp):
    out, st = _batch()
    terms, total = reward_terms(rp, out, st, 0.62, LHV, 1.0)
    expected = _documented(rp, out, st, 0.62, 1.0)
    for i, name in enumerate(REWARD_TERMS):
        np.testing.assert_allclose(terms[:, i], expected[name], rtol=1e-12, atol=1e-12, err_msg=name)
    np.testing.assert_allclose(total, sum(expected.values()), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("flags", [{}, {"battery": False}, {"soc_deviation": True}, {"overheat": True}])
def test_planner_cost_is_minus_the_reward_with_terms_switched_off(flags):
    rp = RewardParams(derate_weight=0.7)
    out, st = _batch(seed=2)
    e = _documented(rp, out, st, 0.6, 1.0)
    expected = e["reward_fuel"] + e["reward_miss"]
    if flags.get("battery", True):
        expected = expected - rp.soc_energy_weight * out[:, C.BATT_CHEM] / (LHV * 0.36 * 0.90)
    if flags.get("soc_deviation", False):
        expected = expected - rp.soc_deviation_weight * ((st[:, C.SOC] - 0.6) / 0.1) ** 2
    if flags.get("overheat", False):
        expected = expected + e["reward_overheat"]
    np.testing.assert_allclose(stage_cost_g(rp, out, st, 0.6, LHV, 1.0, **flags), -expected, rtol=1e-12, atol=1e-9)


def test_prices_are_configurable_and_reach_the_reward():
    out, st = _batch(n=5)
    cheap = RewardParams(prices=Prices(engine_efficiency=0.72))
    a, _ = reward_terms(RewardParams(), out, st, 0.6, LHV)
    b, _ = reward_terms(cheap, out, st, 0.6, LHV)
    miss = REWARD_TERMS.index("reward_miss")
    np.testing.assert_allclose(b[:, miss], a[:, miss] / 2.0, rtol=1e-12)
    assert RewardParams.from_yaml(cheap.to_yaml()) == cheap


def test_env_info_reward_terms_sum_to_the_reward():
    import gymnasium as gym

    import hev_thermal_env  # noqa: F401

    env = gym.make("HevThermal-v0", cycle="beijing", reward={"derate_weight": 0.1})
    env.reset(seed=0)
    for _ in range(50):
        _, r, _, _, info = env.step(np.array([0.5], dtype=np.float32))
        assert r == ((info["reward_fuel"] + info["reward_miss"]) + info["reward_soc"]) + info["reward_overheat"]
