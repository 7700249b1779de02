"""HevThermal-v2: the same MDP on physics v2 (the motor rated where its nameplate says) with the insulation's life as
the overheat price; v1 keeps its defaults."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import hev_thermal_env  # noqa: F401  (registers the ids)
from hev_thermal_env.envs.reward import MOTOR_LIFE_COST_G, RewardParams
from hev_thermal_env.physics import core as C
from hev_thermal_env.physics import paper_bus


def test_v2_passes_the_env_checker_and_drives_the_v2_vehicle():
    env = gym.make("HevThermal-v2", cycle="udds").unwrapped
    check_env(env, skip_render_check=True)
    assert env.config == paper_bus() == paper_bus(physics=2)
    assert env.reward_params == RewardParams() == RewardParams.for_physics(2)


def test_v1_keeps_its_vehicle_and_reward():
    env = gym.make("HevThermal-v1", cycle="udds").unwrapped
    assert env.config == paper_bus(physics=1)
    assert env.reward_params == RewardParams.for_physics(1)
    assert (env.reward_params.overheat_temp_weight, env.reward_params.cutoff_weight) == (0.05, 20.0)


def test_a_reward_mapping_overrides_the_versions_defaults_field_by_field():
    env = gym.make("HevThermal-v2", cycle="udds", reward={"soc_band": 0.02}).unwrapped
    assert env.reward_params.soc_band == 0.02
    assert env.reward_params.motor_life_cost_g == MOTOR_LIFE_COST_G


def test_an_unknown_physics_version_names_the_known_ones():
    with pytest.raises(ValueError, match=r"physics: 3 is not one of \[1, 2\]"):
        gym.make("HevThermal-v1", physics=3)


def test_the_overheat_term_is_the_insulation_life_consumed():
    """Each step's overheat term is −cost · dt / L(T_w) with L = 20,000 h · 2^((180 °C − T_w)/10 K), computed from
    the winding temperature the step reports."""
    env = gym.make("HevThermal-v2", cycle="udds", conditions=hev_thermal_env.Conditions(
        ambient_temp_c=40.0, initial_motor_temp_c=40.0)).unwrapped
    env.reset(seed=0)
    for _ in range(400):
        _, _, _, _, info = env.step(np.array([1.0], dtype=np.float32))
        winding = float(env.phys_state[0, C.WINDING_C])
        life_s = 20000.0 * 3600.0 * 2.0 ** ((180.0 - winding) / 10.0)
        assert info["reward_overheat"] == pytest.approx(-MOTOR_LIFE_COST_G / life_s, rel=1e-9)
    assert MOTOR_LIFE_COST_G / (20000.0 * 3600.0) == pytest.approx(0.058, abs=0.001)  # g/s at the class temperature
    assert math.isfinite(info["reward_overheat"])


def _step(config, u: np.ndarray, v0: float = 8.0, v1: float = 8.5):
    """One step on the flat from ``v0`` to ``v1`` m/s at each motor share of ``u``, from the default start (8 → 8.5:
    traction)."""
    from hev_thermal_env.physics import Conditions
    from hev_thermal_env.physics.core import PhysicsCore

    core = PhysicsCore(config)
    n = len(u)
    state = core.initial_state(Conditions(), n)
    return core.step(state, u, np.full(n, v0), np.full(n, v1), np.zeros(n), core.conditions_array(Conditions(), n))


def test_v2s_engine_off_choice_is_a_band_of_the_action():
    """v2: every share from 1 - engine_min_share up stops the engine and drives as u = 1 does (the motor alone, no
    fuel); just below the band the engine runs. v1: only u = 1 stops it, and u = 0.95 burns fuel for 5 % of the
    torque."""
    band = 1.0 - paper_bus().powertrain.engine_min_share
    u = np.array([band - 0.01, np.float32(band), 0.95, 0.999, 1.0])  # the edge as a float32 action is in the band
    state, out = _step(paper_bus(physics=2), u)
    assert out[0, C.ENGINE_ON] == 1.0 and out[0, C.FUEL_G] > 0.1
    for i in (1, 2, 3):
        np.testing.assert_array_equal(out[i], out[-1])
        np.testing.assert_array_equal(state[i], state[-1])
    assert out[-1, C.ENGINE_ON] == 0.0 and out[-1, C.FUEL_G] == 0.0
    _, out_v1 = _step(paper_bus(physics=1), u)
    assert out_v1[2, C.ENGINE_ON] == 1.0 and out_v1[2, C.FUEL_G] > 0.1 and out_v1[-1, C.FUEL_G] == 0.0
    assert paper_bus(physics=1).powertrain.engine_min_share == 0.0


def test_the_engine_off_band_leaves_braking_and_an_engine_that_never_stops_alone():
    """The band is a traction rule of the stop-start engine: while braking, u = 0.95 still takes 95 % of the
    available regeneration; with stop-start off, u = 0.95 still gives the motor 95 % of the demand."""
    bus = paper_bus()
    no_stop = bus.replace(powertrain=bus.powertrain.replace(stop_start=False))
    for config, v0, v1 in ((bus, 8.5, 7.5), (no_stop, 8.0, 8.5)):
        _, out = _step(config, np.array([0.95, 1.0]), v0, v1)
        assert out[0, C.MOTOR_TORQUE] == pytest.approx(0.95 * out[1, C.MOTOR_TORQUE], rel=1e-9)
        assert out[1, C.MOTOR_TORQUE] != 0.0


@pytest.mark.parametrize("dv", [0.1, 0.2, 0.5, 1.2])
def test_v2s_charge_yields_to_the_demand(dv):
    """v2: a charge the engine at full load cannot carry on top of the demand is cut down before the trace is missed:
    at 15 m/s with the engine saturated or nearly so, u = -1 and -0.5 miss no more than u = 0 (the motor unused), and
    the motor never assists below u = 0. v1: the charge is kept and the bus misses more."""
    u = np.array([-1.0, -0.5, 0.0])
    missed = {}
    for physics in (1, 2):
        _, out = _step(paper_bus(physics=physics), u, 15.0, 15.0 + dv)
        missed[physics] = out[:, C.MISSED_J]
        if physics == 2:
            np.testing.assert_allclose(out[:, C.MISSED_J], out[2, C.MISSED_J], rtol=1e-9, atol=1e-6)
            assert np.all(out[:, C.MOTOR_TORQUE] <= 0.0)
    assert missed[1][0] > missed[2][0] + 1.0 or missed[1][0] == missed[2][0] == 0.0


def test_a_tie_within_the_engine_off_band_resolves_to_u_1():
    """Equally cheap candidates give the smallest |u| (a cut-off motor: u = 0), but a tie wholly within v2's band
    gives u = 1, the band's canonical action (what a teacher's demonstrations and the traces show)."""
    from hev_thermal_env.planning.problem import argmin_small_action

    off_from = paper_bus().powertrain.engine_off_from
    u = np.array([-0.5, 0.0, 0.5, 0.9, 0.95, 1.0])
    band_tie = np.array([3.0, 2.0, 1.5, 1.0, 1.0, 1.0])
    assert argmin_small_action(band_tie, u, engine_off_from=off_from) == 5
    assert argmin_small_action(np.ones(6), u, engine_off_from=off_from) == 1
    assert argmin_small_action(band_tie, u, engine_off_from=paper_bus(physics=1).powertrain.engine_off_from) == 3
    assert paper_bus(physics=1).powertrain.engine_off_from == 1.0
