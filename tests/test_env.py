"""HevThermal-v2: API checks, seeding, actions, the physics it wraps, observations, options, rendering."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import hev_thermal_env
from hev_thermal_env import Conditions, list_cycles, load_cycle, paper_bus, simulate
from hev_thermal_env.envs import INFO_KEYS, HevThermalEnv, observation_names
from hev_thermal_env.envs.episodes import RESET_OPTIONS
from hev_thermal_env.envs.reward import REWARD_TERMS, RewardParams, reward_terms
from hev_thermal_env.envs.spaces import coolant_mode, cycle_name
from hev_thermal_env.physics import core
from hev_thermal_env.scenarios import get_scenario, list_scenarios

DESIGN_INFO_KEYS = (
    "fuel_g", "soc", "motor_temp_c", "heat_index", "motor_torque_nm", "motor_speed_rpm", "motor_heat_w",
    "engine_torque_nm", "engine_speed_rpm", "engine_on", "gear", "speed_mps", "trace_miss_mps", "motor_cutoff",
    "coolant_on", "reward_fuel", "reward_overheat", "reward_soc", "reward_miss",
)


def make(**kwargs) -> gym.Env:
    kwargs.setdefault("cycle", "hwfet")
    return gym.make("HevThermal-v2", **kwargs)


def rollout(env: gym.Env, seed: int, n: int, action_seed: int = 0, options=None):
    """(obs list, rewards, infos) of n steps with seeded random actions (resetting at truncation)."""
    rng = np.random.default_rng(action_seed)
    obs, info = env.reset(seed=seed, options=options)
    out = [(obs, 0.0, info)]
    for _ in range(n):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, size=1).astype(np.float32))
        out.append((obs, r, info))
        if term or trunc:
            obs, info = env.reset()
            out.append((obs, 0.0, info))
    return out


def same_trajectory(a, b) -> bool:
    return len(a) == len(b) and all(
        np.array_equal(oa, ob) and ra == rb and ia == ib for (oa, ra, ia), (ob, rb, ib) in zip(a, b))


# --- API ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("scenario", list_scenarios())
def test_checkers_pass_without_warnings(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = make(scenario=scenario)
        gym_check_env(env.unwrapped)
        sb3_check_env(env)
        env.close()


def test_spaces():
    env = make().unwrapped
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    space = env.observation_space
    assert space.dtype == np.float32 and space.shape == (21,)
    assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high)) and np.all(space.low < space.high)
    assert len(env.obs_names) == space.shape[0] == len(observation_names(10, 2))
    assert env.obs_names[-1] == "preview_speed_10s_mps"
    assert make(preview_s=0).observation_space.shape == (16,)
    assert make(preview_s=30, preview_step_s=5).observation_space.shape == (22,)
    with pytest.raises(ValueError):
        make(preview_s=-1)


@pytest.mark.parametrize("kind", ["name", "path", "cycle", "list", "random_bus"])
def test_cycle_argument(kind, tmp_path):
    hwfet = load_cycle("hwfet")
    arg = {"name": "hwfet", "path": str(hwfet.to_csv(tmp_path / "mine.csv")), "cycle": hwfet,
           "list": ["hwfet", "us06", "beijing"], "random_bus": "random_bus"}[kind]
    env = make(cycle=arg)
    obs, info = env.reset(seed=3)
    assert obs in env.observation_space
    cyc = env.unwrapped.cycle
    if kind in ("name", "path", "cycle"):
        np.testing.assert_array_equal(cyc.speed_mps, hwfet.speed_mps)
    if kind == "random_bus":
        assert cyc.synthetic and cycle_name(info["cycle_id"]).startswith("random_bus:")
        assert cycle_name(info["cycle_id"]) == cyc.name
        np.testing.assert_array_equal(load_cycle(cyc.name).speed_mps, cyc.speed_mps)  # the name reloads the cycle
    env.step(np.array([0.0], np.float32))


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown cycle"):
        make(cycle="nope")
    with pytest.raises(ValueError, match="unknown scenario"):
        make(scenario="nope")
    with pytest.raises(ValueError, match="render_mode"):
        HevThermalEnv(render_mode="ascii")
    with pytest.raises(ValueError):
        make(cycle=[])
    with pytest.raises(ValueError, match="unknown field"):
        make(reward={"fuel_wieght": 1.0})


# --- seeding --------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs", [
    {"scenario": "random"},
    {"cycle": "random_bus"},
    {"cycle": ["hwfet", "us06", "udds", "beijing", "wltc_3b"]},
    {"random_start": True},
])
def test_same_seed_same_trajectory_different_seed_differs(kwargs):
    env = make(**kwargs)
    a = rollout(env, seed=11, n=40)
    b = rollout(env, seed=11, n=40)
    assert same_trajectory(a, b)
    assert same_trajectory(a, rollout(make(**kwargs), seed=11, n=40))
    others = [rollout(env, seed=s, n=3)[0] for s in (12, 13, 14, 15)]
    assert any(not np.array_equal(a[0][0], o[0]) or a[0][2] != o[2] for o in others)


def test_fixed_scenario_ignores_seed():
    env = make(scenario="paper")
    a, _ = env.reset(seed=1)
    b, _ = env.reset(seed=2)
    np.testing.assert_array_equal(a, b)


# --- actions --------------------------------------------------------------------------------------

@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises(bad):
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([bad], np.float32))


@pytest.mark.parametrize("bad", [np.zeros(2), np.zeros((1, 1)), np.float32(0.2), np.zeros(0)])
def test_wrong_action_shape_raises_with_expected_shape(bad):
    env = make().unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"\(1,\)"):
        env.step(bad)


def test_out_of_range_action_is_clipped():
    env = make().unwrapped
    results = {}
    for a in (5.0, 1.0, -7.0, -1.0):
        env.reset(seed=0)
        for _ in range(60):
            out = env.step(np.array([a]))
        results[a] = out
    for big, edge in ((5.0, 1.0), (-7.0, -1.0)):
        o1, r1, _, _, i1 = results[big]
        o2, r2, _, _, i2 = results[edge]
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2
        assert i1["motor_share_clipped"] and not i2["motor_share_clipped"]
        assert {k: v for k, v in i1.items() if k != "motor_share_clipped"} == \
               {k: v for k, v in i2.items() if k != "motor_share_clipped"}


# --- the physics it wraps -------------------------------------------------------------------------

def test_whole_hwfet_episode_matches_simulate():
    env = make(cycle="hwfet")
    env.reset(seed=0)
    fuel, steps, total_reward, terms_sum = 0.0, 0, 0.0, 0.0
    while True:
        obs, r, term, trunc, info = env.step(np.array([0.3]))
        fuel += info["fuel_g"]
        total_reward += r
        terms_sum += info["reward_fuel"] + info["reward_miss"] + info["reward_soc"] + info["reward_overheat"]
        steps += 1
        assert term is False
        if trunc:
            break
    ref = simulate("hwfet", paper_bus(), 0.3)
    assert steps == load_cycle("hwfet").n_steps
    assert fuel == pytest.approx(ref.summary["fuel_g"], rel=1e-9)
    assert info["soc"] == pytest.approx(ref.summary["soc_final"], rel=1e-9)
    assert total_reward == pytest.approx(terms_sum, rel=1e-12)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.array([0.3]))


def test_info_contract_and_reward_terms():
    env = make(scenario="hot").unwrapped
    obs, info = env.reset(seed=0)
    assert tuple(info) == INFO_KEYS
    for _ in range(200):
        state_before = env.phys_state.copy()
        obs, r, term, trunc, info = env.step(np.array([0.8], np.float32))
    assert tuple(info) == INFO_KEYS
    assert set(DESIGN_INFO_KEYS) <= set(info)
    out = env.last_out
    assert info["motor_speed_rpm"] == pytest.approx(out[core.MOTOR_SPEED] * 30 / math.pi)
    assert info["engine_speed_rpm"] == pytest.approx(out[core.ENGINE_SPEED] * 30 / math.pi)
    assert info["soc"] == env.phys_state[0, core.SOC] and info["motor_temp_c"] == env.phys_state[0, core.TEMP_C]
    assert type(info["engine_on"]) is np.bool_ and type(info["gear"]) is np.int64
    assert info["time_s"] == env.k and info["cycle_speed_mps"] == env.cycle.speed_mps[env.k]
    terms = reward_terms(env.reward_params, out[None, :], env.phys_state, env.soc_target,
                         env.config.engine.fuel_lhv_j_per_g, state_before=state_before)
    terms, _ = terms
    for i, key in enumerate(REWARD_TERMS):
        assert info[key] == terms[0, i]
    assert r == pytest.approx(sum(info[k] for k in REWARD_TERMS), rel=1e-12)
    assert state_before.shape == (1, core.N_STATE)


def test_reward_argument():
    env = make(reward={"fuel_weight": 2.0}).unwrapped
    assert env.reward_params == RewardParams(fuel_weight=2.0)
    env.reset(seed=0)
    burned = []
    for _ in range(100):
        _, _, _, _, info = env.step(np.array([-0.5]))
        assert info["reward_fuel"] == -2.0 * info["fuel_g"]
        burned.append(info["fuel_g"])
    assert max(burned) > 0
    env2 = make(reward=RewardParams(miss_weight=5.0))
    assert env2.unwrapped.reward_params.miss_weight == 5.0


def test_hot_scenario_aggressive_split_derates_and_cuts_out():
    env = make(cycle="hwfet", scenario="hot")
    env.reset(seed=0)
    cut, pwm = [], []
    while True:
        _, _, _, trunc, info = env.step(np.array([0.6]))
        cut.append(info["motor_cutoff"])
        pwm.append(info["heat_index"])
        if trunc:
            break
    ref = simulate("hwfet", paper_bus(), 0.6, get_scenario("hot").conditions)
    assert max(pwm) > 0.0 and any(cut)
    np.testing.assert_array_equal(np.array(cut, dtype=float), ref.trace["motor_cutoff"])
    # the paper's baseline motor has no cutoff
    env = make(cycle="hwfet", scenario="hot", thermal=False)
    assert env.unwrapped.config.thermal.enabled is False
    env.reset(seed=0)
    for _ in range(500):
        _, _, _, _, info = env.step(np.array([0.6]))
        assert not info["motor_cutoff"]


# --- contract attributes, peek ----------------------------------------------------------------------

def test_contract_attributes():
    env = make(conditions=Conditions(initial_soc=0.6, ambient_temp_c=30.0)).unwrapped
    obs, _ = env.reset(seed=0, options={"start_s": 100})
    assert env.config == paper_bus()
    assert isinstance(env.core, core.PhysicsCore) and env.core.config is env.config
    assert env.conditions.initial_soc == 0.6 and env.soc_target == 0.6
    assert env.cycle.name == "hwfet" and env.k == 100
    assert env.phys_state.shape == (1, core.N_STATE) and env.phys_state.dtype == np.float64
    assert env.cond.shape == (1, core.N_COND) and env.cond[0, core.AMBIENT_C] == 30.0
    assert env.last_out.shape == (core.N_OUT,) and not env.last_out.any()
    assert isinstance(env.reward_params, RewardParams)
    names = env.obs_names
    assert obs[names.index("speed_mps")] == np.float32(env.cycle.speed_mps[100])
    assert obs[names.index("cycle_progress")] == np.float32(100 / env.cycle.n_steps)
    assert obs[names.index("soc")] == np.float32(0.6)
    assert obs[names.index("preview_speed_4s_mps")] == np.float32(env.cycle.speed_mps[104])
    assert obs[names.index("motor_torque_avail_nm")] == np.float32(env.peek(np.zeros(1))[1][0, core.MOTOR_AVAIL])
    env.step(np.array([0.5], np.float32))
    assert env.k == 101 and env.last_out.any()
    obs, *_ = env.step(np.array([0.5], np.float32))
    assert obs[names.index("motor_torque_avail_nm")] == np.float32(env.last_out[core.MOTOR_AVAIL])
    assert obs[names.index("gear")] >= 1


def test_peek_predicts_the_step_without_changing_the_env():
    env = make(scenario="random").unwrapped
    env.reset(seed=5)
    for _ in range(150):
        env.step(np.array([0.4]))
    before = (env.k, env.phys_state.copy(), env.last_out.copy())
    grid = np.linspace(-1.0, 1.0, 21)
    states, outs = env.peek(grid)
    assert states.shape == (21, core.N_STATE) and outs.shape == (21, core.N_OUT)
    assert env.k == before[0]
    np.testing.assert_array_equal(env.phys_state, before[1])
    np.testing.assert_array_equal(env.last_out, before[2])
    env.step(np.array([grid[14]]))
    np.testing.assert_array_equal(states[14], env.phys_state[0])
    np.testing.assert_array_equal(outs[14], env.last_out)
    with pytest.raises(ValueError):
        env.peek(np.array([0.1, np.nan]))


# --- observations ---------------------------------------------------------------------------------

@pytest.mark.parametrize("scenario", list_scenarios())
def test_observations_inside_bounds_on_every_cycle(scenario):
    env = make(cycle="hwfet", scenario=scenario)
    space = env.observation_space
    rng = np.random.default_rng(1)
    for name in hev_thermal_env.list_cycles():
        n = load_cycle(name).n_steps
        obs, _ = env.reset(seed=2, options={"cycle": name, "start_s": max(n - 300, 0)})
        assert space.contains(obs)
        trunc = False
        while not trunc:
            obs, _, _, trunc, _ = env.step(rng.uniform(-1.0, 1.0, size=1).astype(np.float32))
            assert space.contains(obs), (name, scenario, obs)


def test_extreme_conditions_stay_inside_bounds():
    env = make(cycle="us06", thermal=False, conditions=Conditions(ambient_temp_c=60.0, initial_motor_temp_c=150.0,
                                                                 coolant="off", initial_soc=0.8))
    obs, _ = env.reset(seed=0)
    trunc = False
    while not trunc:
        assert env.observation_space.contains(obs)
        obs, _, _, trunc, _ = env.step(np.array([1.0], np.float32))


# --- reset options ---------------------------------------------------------------------------------

def test_reset_options():
    env = make().unwrapped
    _, info = env.reset(seed=0, options={"cycle": "us06", "ambient_temp_c": 35.0, "initial_motor_temp_c": 45.0,
                                         "initial_soc": 0.55, "coolant": "off", "start_s": 42})
    assert env.cycle.name == "us06" and env.k == 42 and info["start_s"] == 42
    c = env.conditions
    assert (c.ambient_temp_c, c.initial_motor_temp_c, c.initial_soc, c.coolant) == (35.0, 45.0, 0.55, "off")
    assert env.soc_target == 0.55 and env.phys_state[0, core.TEMP_C] == 45.0
    assert coolant_mode(info["coolant_code"]) == "off" and info["soc_target"] == 0.55
    assert cycle_name(info["cycle_id"]) == "us06" and info["cycle_id"] == list_cycles().index("us06")
    env.reset()
    assert env.cycle.name == "hwfet" and env.k == 0 and env.conditions == Conditions()
    with pytest.raises(ValueError, match="valid options") as exc:
        env.reset(options={"ambient": 30.0})
    for key in RESET_OPTIONS:
        assert key in str(exc.value)
    with pytest.raises(ValueError, match="start_s"):
        env.reset(options={"start_s": 10_000})
    with pytest.raises(ValueError, match="start_s"):
        env.reset(options={"start_s": 1.5})
    for bad in ("cold", ["on"]):
        with pytest.raises(ValueError, match=r"reset option coolant: .* is not one of \['on'"):
            env.reset(options={"coolant": bad})
    with pytest.raises(ValueError, match="initial_soc"):
        env.reset(options={"initial_soc": 0.95})


def test_random_start_and_truncation():
    env = make(cycle="us06", random_start=True)
    starts = set()
    for seed in range(5):
        _, info = env.reset(seed=seed)
        starts.add(info["start_s"])
    assert len(starts) > 1
    _, info = env.reset(options={"start_s": 597})
    results = [env.step(np.array([0.0], np.float32)) for _ in range(3)]
    assert [r[3] for r in results] == [False, False, True]
    assert not any(r[2] for r in results)


def test_soc_offset_starts_off_the_target_and_the_band_holds_to_the_target():
    """``soc_offset``: the episode starts within that much SOC of its target (the scenario's draw, which the episode
    without an offset starts on) and the observation's deviation is the start's distance from it; 0 changes nothing;
    the vector env lives through the same episodes."""
    from hev_thermal_env.envs import HevThermalVectorEnv

    kw = {"cycle": "random_bus", "scenario": "random_service"}
    names = observation_names(10, 2)
    i_soc, i_dev = names.index("soc"), names.index("soc_deviation")
    offsets = []
    for seed in range(12):
        plain, off = make(**kw), make(**kw, soc_offset=0.05)
        o0, _ = plain.reset(seed=seed)
        o1, info = off.reset(seed=seed)
        target = float(o0[i_soc])  # the same draws: the plain episode starts on the target
        assert off.unwrapped.soc_target == pytest.approx(target) and info["soc"] == pytest.approx(float(o1[i_soc]),
                                                                                                    abs=1e-6)
        offsets.append(float(o1[i_soc]) - target)
        assert float(o1[i_dev]) == pytest.approx(offsets[-1], abs=1e-6)
        assert np.array_equal(o0, make(**kw, soc_offset=0.0).reset(seed=seed)[0])
    assert max(map(abs, offsets)) <= 0.05 + 1e-6 and min(offsets) < -0.01 and max(offsets) > 0.01
    vec = HevThermalVectorEnv(3, **kw, soc_offset=0.05)
    obs, _ = vec.reset(seed=[4, 5, 6])
    for row, seed in enumerate((4, 5, 6)):
        assert np.array_equal(obs[row], make(**kw, soc_offset=0.05).reset(seed=seed)[0])
    asked = make(**kw, soc_offset=0.05)
    obs, _ = asked.reset(seed=3, options={"initial_soc": 0.6})  # a start asked for is never shifted
    assert float(obs[i_soc]) == pytest.approx(0.6, abs=1e-6) and asked.unwrapped.soc_target == 0.6
    assert float(obs[i_dev]) == pytest.approx(0.0, abs=1e-6)
    for bad in (-0.01, 0.3, True, "0.1"):
        with pytest.raises(ValueError, match="soc_offset"):
            make(soc_offset=bad)


# --- rendering -------------------------------------------------------------------------------------

def test_render_rgb_array():
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    frame0 = env.render()
    for _ in range(50):
        env.step(np.array([0.5], np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.shape[:2] == (640, 640)
    assert frame.shape == frame0.shape and not np.array_equal(frame, frame0)
    env.close()


def test_render_human_runs_headless_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = make(render_mode="human")
        env.reset(seed=0)
        for _ in range(3):
            env.step(np.array([0.5], np.float32))
        assert env.render() is None
        env.close()


def test_direct_construction_matches_make():
    a = HevThermalEnv(cycle="udds", scenario="random")
    b = make(cycle="udds", scenario="random")
    oa, ia = a.reset(seed=4)
    ob, ib = b.reset(seed=4)
    np.testing.assert_array_equal(oa, ob)
    assert ia == ib


def test_the_previous_version_fails_with_one_line_naming_the_current_id():
    with pytest.raises(gym.error.DeprecatedEnv, match="HevThermal-v2"):
        gym.make("HevThermal-v0")


def test_braking_share_governs_regeneration_and_the_winding_is_observed():
    """While braking, u = 1 regenerates, u = 0 and u < 0 brake by friction alone (motor torque 0, friction brakes
    take all); the observation's winding entry is the info's winding temperature."""
    names = hev_thermal_env.envs.spaces.observation_names(10, 2)
    regen, friction = {}, {}
    for u in (1.0, 0.0, -1.0):
        env = gym.make("HevThermal-v2", cycle="udds")
        env.reset(seed=0)
        torque, brake = [], []
        for _ in range(300):
            obs, _, _, _, info = env.step(np.array([u], dtype=np.float32))
            out = env.unwrapped.last_out
            if out[core.SHAFT_DEMAND] < 0.0 and out[core.SPEED] > 1.0:
                torque.append(out[core.MOTOR_TORQUE])
                brake.append(out[core.BRAKE_POWER])
        assert obs[names.index("winding_temp_c")] == pytest.approx(info["winding_temp_c"], rel=1e-6)
        regen[u], friction[u] = np.array(torque), np.array(brake)
    assert len(regen[1.0]) > 10 and np.all(regen[1.0] < 0.0)
    assert np.all(regen[0.0] == 0.0) and np.all(regen[-1.0] == 0.0)
    assert friction[0.0].sum() > friction[1.0].sum() > 0.0
