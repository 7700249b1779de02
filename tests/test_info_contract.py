"""The info contract every reader accepts: numpy values, one set of keys in one order at resets and steps (neutral
values at a reset), in the single env, the vector env and gymnasium's vector wrappers; torchrl's default info reader
and Minari's ``DataCollector(record_infos=True)`` on the single env; the safety cost ``info["cost"]``."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import hev_thermal_env  # noqa: F401  (registers HevThermal-v2)
from hev_thermal_env import load_cycle
from hev_thermal_env.envs import (
    EPISODE_INFO_KEYS,
    INFO_DTYPES,
    INFO_KEYS,
    HevThermalVectorEnv,
)
from hev_thermal_env.envs.spaces import STATE_INFO_KEYS, coolant_mode, cycle_name

RANDOM_KW = {"cycle": ["hwfet", "random_bus"], "scenario": "random"}


@pytest.fixture(scope="module")
def short_cycle(tmp_path_factory) -> str:
    """A 41 s slice of UDDS: episodes end quickly."""
    path = tmp_path_factory.mktemp("info") / "udds_41s.csv"
    v = load_cycle("udds").speed_mps[20:61]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return str(path)


def _types_ok(info: dict) -> list[tuple[str, str]]:
    """The keys whose value is not exactly its documented numpy type."""
    return [(k, type(v).__name__) for k, v in info.items() if type(v) is not INFO_DTYPES[k]]


# --- the single env ------------------------------------------------------------------------------------------

def test_reset_and_steps_give_the_same_keys_in_the_same_order_as_numpy_scalars():
    assert "action" not in INFO_KEYS and "action_clipped" not in INFO_KEYS  # torchrl's reserved entries
    assert set(EPISODE_INFO_KEYS) <= set(STATE_INFO_KEYS) <= set(INFO_KEYS) and set(INFO_DTYPES) == set(INFO_KEYS)
    env = gym.make("HevThermal-v2", **RANDOM_KW)
    rng = np.random.default_rng(0)
    for seed in (1, 2, 3):
        _, info = env.reset(seed=seed)
        infos = [info] + [env.step(rng.uniform(-1, 1, 1).astype(np.float32))[4] for _ in range(5)]
        for i in infos:
            assert tuple(i) == INFO_KEYS and not _types_ok(i)
            assert all(i[k] == info[k] for k in EPISODE_INFO_KEYS)
        assert cycle_name(info["cycle_id"]) == env.unwrapped.cycle.name
        assert coolant_mode(info["coolant_code"]) == env.unwrapped.conditions.coolant


def test_a_reset_reports_the_starting_state_and_zero_for_the_quantities_of_a_step():
    env = gym.make("HevThermal-v2", cycle="udds", scenario="hot")
    _, info = env.reset(seed=0, options={"start_s": 100, "initial_soc": 0.61})
    e = env.unwrapped
    cond = e.conditions
    assert info["soc"] == 0.61 and info["motor_temp_c"] == cond.initial_motor_temp_c == 50.0
    assert info["time_s"] == info["start_s"] == 100 and info["soc_target"] == 0.61
    assert info["speed_mps"] == info["cycle_speed_mps"] == load_cycle("udds").speed_mps[100]
    assert info["ambient_temp_c"] == 40.0 and not info["motor_cutoff"] and not info["winding_trip"]
    obs = e._rows.observe()[0]
    assert info["motor_torque_avail_nm"] == pytest.approx(obs[e.obs_names.index("motor_torque_avail_nm")], rel=1e-6)
    step_keys = [k for k in INFO_KEYS if k not in STATE_INFO_KEYS]
    assert {"fuel_g", "cost", "reward_fuel", "motor_share", "gear", "engine_on"} <= set(step_keys)
    assert all(info[k] == 0 for k in step_keys), {k: info[k] for k in step_keys if info[k] != 0}


def test_info_keys_keep_their_order_at_resets_and_steps():
    keys = ("cost", "fuel_g", "cycle_id", "engine_on")
    env = gym.make("HevThermal-v2", info_keys=keys)
    _, info = env.reset(seed=0)
    assert tuple(info) == keys and not _types_ok(info)
    info = env.step(np.ones(1, np.float32))[4]
    assert tuple(info) == keys and not _types_ok(info)


# --- vector forms ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_the_vector_envs_info_arrays_keep_one_dtype_through_resets(mode):
    vec = HevThermalVectorEnv(3, max_episode_steps=4, autoreset_mode=mode, **RANDOM_KW)
    _, info = vec.reset(seed=0)
    seen_reset = False
    for _ in range(12):
        keys = [k for k in info if not k.startswith("_") and not k.startswith("final_")]
        assert keys == list(INFO_KEYS)
        for k in INFO_KEYS:
            assert info[k].dtype == INFO_DTYPES[k] and info[k].shape == (3,) and info["_" + k].all(), k
        if "final_info" in info:
            assert all(info["final_info"][k].dtype == INFO_DTYPES[k] for k in INFO_KEYS)
        _, _, _, trunc, info = vec.step(np.full((3, 1), 0.5, np.float32))
        seen_reset |= bool(trunc.any()) or bool((info["time_s"] == 0).any())
    assert seen_reset


def test_gymnasiums_sync_vector_env_keeps_the_numeric_dtypes_and_the_native_values():
    """gymnasium batches numpy numbers into arrays of their dtype but ``np.bool_`` values into object arrays (it
    batches Python bools and ``np.number`` only); their values are the native vector env's."""
    sync = gym.make_vec("HevThermal-v2", 2, vectorization_mode="sync", cycle="udds")
    native = HevThermalVectorEnv(2, cycle="udds")
    pairs = [(sync.reset(seed=0)[1], native.reset(seed=0)[1])]
    for _ in range(60):
        a = np.ones((2, 1), np.float32)
        pairs.append((sync.step(a)[4], native.step(a)[4]))
    for s, n in pairs:
        for k in INFO_KEYS:
            assert s["_" + k].all() and s[k].dtype == (object if INFO_DTYPES[k] is np.bool_ else INFO_DTYPES[k]), k
            np.testing.assert_array_equal(s[k].astype(INFO_DTYPES[k]), n[k])
    assert any(s["engine_on"].astype(bool).any() for s, _ in pairs)


# --- the readers -------------------------------------------------------------------------------------------------

def test_torchrls_default_info_reader_on_the_single_env(short_cycle):
    pytest.importorskip("torchrl")  # the [dev] extra installs it
    import torch
    from torchrl.envs import GymWrapper, default_info_dict_reader
    from torchrl.envs.utils import check_env_specs

    warnings.filterwarnings("ignore", category=UserWarning)
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    env = GymWrapper(gym.make("HevThermal-v2", cycle=short_cycle)).auto_register_info_dict()
    check_env_specs(env)
    td = env.rollout(100, break_when_any_done=False)  # two episode ends, each followed by a reset
    nxt = td["next"]
    assert td.shape == (100,) and nxt["truncated"].sum().item() == 2
    assert {"cost", "fuel_g", "gear", "engine_on", "cycle_id"} <= set(nxt.keys())
    assert nxt["cost"].dtype == torch.float64 and nxt["gear"].dtype == torch.int64
    assert nxt["engine_on"].dtype == torch.bool and nxt["fuel_g"].min().item() >= 0.0
    plain = GymWrapper(gym.make("HevThermal-v2", cycle=short_cycle))
    plain.set_info_dict_reader(default_info_dict_reader())
    assert plain.rollout(50, break_when_any_done=False)["next", "motor_share"].shape == (50,)


def test_minaris_data_collector_records_the_infos(short_cycle, tmp_path, monkeypatch):
    minari = pytest.importorskip("minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    env = minari.DataCollector(gym.make("HevThermal-v2", cycle=short_cycle), record_infos=True, data_format="arrow")
    env.reset(seed=0)
    for _ in range(45):  # across the end of the 40-step episode
        if env.step(env.action_space.sample())[3]:
            env.reset()
    dataset = env.create_dataset(dataset_id="hev-thermal/test/random-v0", algorithm_name="random")
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == 2 and len(episodes[0].actions) == 40
    assert set(episodes[0].infos) == set(INFO_KEYS) and episodes[0].infos["cost"].shape == (41,)


# --- the safety cost -----------------------------------------------------------------------------------------------

def _drive(u: float, scenario: str, **kw) -> dict[str, np.ndarray]:
    env = gym.make("HevThermal-v2", cycle="hwfet", scenario=scenario, **kw)
    _, info = env.reset(seed=0)
    assert info["cost"] == 0.0
    rows, trunc = [], False
    while not trunc:
        _, _, _, trunc, info = env.step(np.array([u], np.float32))
        rows.append(info)
    return {k: np.array([r[k] for r in rows]) for k in INFO_KEYS}


def test_the_safety_cost_counts_seconds_of_lost_motor_capability():
    hot = _drive(1.0, "hot")  # a thermal-blind aggressive split in the hot scenario derates and cuts off
    cost = hot["cost"]
    stopped = hot["motor_cutoff"] | hot["winding_trip"]
    assert stopped.any() and (hot["heat_index"] > 0).any()
    assert np.all((cost >= 0.0) & (cost <= 1.0))
    assert np.all(cost[stopped] == 1.0)
    # a motor stopped before the step (and so after it) gives no torque in it
    held = stopped[1:] & stopped[:-1] & (hot["motor_speed_rpm"][1:] > 0)
    assert held.any() and np.all(hot["motor_torque_avail_nm"][1:][held] == 0.0)
    assert np.all(cost[~stopped] == hot["heat_index"][~stopped])
    # the episode's safety cost lies between the seconds stopped and the seconds derated or stopped
    assert stopped.sum() <= cost.sum() <= (stopped | (hot["heat_index"] > 0)).sum()
    assert not any(np.any(_drive(u, sc, **kw)["cost"]) for u, sc, kw in
                   ((0.0, "paper", {}), (1.0, "hot", {"thermal": False})))  # motor unused; no thermal model
