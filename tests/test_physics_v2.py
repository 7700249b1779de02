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
