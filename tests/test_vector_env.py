"""The native vector env (same trajectories as single envs), its SB3 adapter, and the generic vectorisers."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

import hev_thermal_env  # noqa: F401  (registers HevThermal-v2)
from hev_thermal_env.envs import INFO_KEYS, HevThermalVectorEnv
from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.physics import core
from hev_thermal_env.wrappers.sb3 import Sb3VecEnv

# randomised everywhere: conditions, cycle choice (lengths differ), random bus cycles, start offsets
RANDOM_KW = {"cycle": ["hwfet", "us06", "random_bus"], "scenario": "random", "random_start": True}


def actions_for(n_envs: int, n_steps: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.2, 1.2, size=(n_steps, n_envs, 1)).astype(np.float32)


def single_envs(n: int, max_steps: int, **kw) -> list[gym.Env]:
    return [gym.make("HevThermal-v2", max_episode_steps=max_steps, **kw) for _ in range(n)]


def test_spaces_and_metadata():
    envs = HevThermalVectorEnv(3)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.single_action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    assert envs.action_space.shape == (3, 1)
    assert envs.observation_space.shape == (3, 21) and envs.observation_space.dtype == np.float32
    assert envs.single_observation_space == gym.make("HevThermal-v2").observation_space
    assert HevThermalVectorEnv(2, autoreset_mode="SameStep").metadata["autoreset_mode"] == AutoresetMode.SAME_STEP


def test_next_step_autoreset_matches_single_envs():
    n, max_steps, n_steps = 4, 25, 90
    vec = HevThermalVectorEnv(n, max_episode_steps=max_steps, **RANDOM_KW)
    singles = single_envs(n, max_steps, **RANDOM_KW)
    obs_v, info_v = vec.reset(seed=100)
    for i, env in enumerate(singles):
        obs, info = env.reset(seed=100 + i)
        np.testing.assert_array_equal(obs_v[i], obs)
        for key in INFO_KEYS:
            assert info_v[key][i] == info[key]
    done = np.zeros(n, dtype=bool)
    n_resets = 0
    for actions in actions_for(n, n_steps):
        obs_v, rew_v, term_v, trunc_v, info_v = vec.step(actions)
        for i, env in enumerate(singles):
            if done[i]:
                obs, info = env.reset()
                n_resets += 1
                assert rew_v[i] == 0.0 and not trunc_v[i] and info_v["fuel_g"][i] == 0.0
                for key in INFO_KEYS:
                    assert info_v["_" + key][i] and info_v[key][i] == info[key], key
            else:
                obs, rew, term, trunc, info = env.step(actions[i])
                assert rew_v[i] == rew and term_v[i] == term and trunc_v[i] == trunc
                for key in INFO_KEYS:
                    assert info_v["_" + key][i] and info_v[key][i] == info[key], key
            np.testing.assert_array_equal(obs_v[i], obs)
        assert not term_v.any()
        done = trunc_v | term_v
    assert n_resets >= n


def test_autoreset_into_a_longer_cycle_matches_single_envs():
    # the first episodes run US06 (600 s); autoresets then draw 1300 s random bus cycles, which widens the tables
    kw = {"cycle": ["us06", "random_bus"], "scenario": "random"}
    n, max_steps = 4, 6
    vec = HevThermalVectorEnv(n, max_episode_steps=max_steps, **kw)
    singles = single_envs(n, max_steps, **kw)
    first = [{"cycle": "us06", "start_s": 595 - i} for i in range(n)]  # staggered ends
    obs_v, _ = vec.reset(seed=40, options=first)
    width = vec._rows.tables.shape[2]
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(env.reset(seed=40 + i, options=first[i])[0], obs_v[i])
    done = np.zeros(n, dtype=bool)
    for actions in actions_for(n, 30, seed=2):
        obs_v, rew_v, _, trunc_v, info_v = vec.step(actions)
        for i, env in enumerate(singles):
            if done[i]:
                obs, _ = env.reset()
            else:
                obs, rew, _, _, info = env.step(actions[i])
                assert rew_v[i] == rew and all(info_v[key][i] == info[key] for key in INFO_KEYS)
            np.testing.assert_array_equal(obs_v[i], obs)
        done = trunc_v
    assert vec._rows.tables.shape[2] > width  # the tables widened for a longer cycle


def test_same_step_autoreset_matches_single_envs():
    n, max_steps = 3, 20
    vec = HevThermalVectorEnv(n, max_episode_steps=max_steps, autoreset_mode=AutoresetMode.SAME_STEP, **RANDOM_KW)
    singles = single_envs(n, max_steps, **RANDOM_KW)
    vec.reset(seed=[7, 8, 9])
    for env, s in zip(singles, (7, 8, 9)):
        env.reset(seed=s)
    finals = 0
    for actions in actions_for(n, 50, seed=3):
        obs_v, rew_v, term_v, trunc_v, info_v = vec.step(actions)
        for i, env in enumerate(singles):
            obs, rew, term, trunc, info = env.step(actions[i])
            assert rew_v[i] == rew and trunc_v[i] == trunc
            if trunc:
                finals += 1
                assert info_v["_final_obs"][i] and info_v["_final_info"][i]
                np.testing.assert_array_equal(info_v["final_obs"][i], obs)
                for key in INFO_KEYS:
                    assert info_v["final_info"][key][i] == info[key]
                obs, info = env.reset()
                for key in INFO_KEYS:
                    assert info_v[key][i] == info[key]
            else:
                assert "_final_obs" not in info_v or not info_v["_final_obs"][i]
                for key in INFO_KEYS:
                    assert info_v[key][i] == info[key]
            np.testing.assert_array_equal(obs_v[i], obs)
    assert finals >= n


def test_different_cycle_lengths_truncate_per_env():
    vec = HevThermalVectorEnv(2, autoreset_mode=AutoresetMode.DISABLED)
    vec.reset(seed=0, options=[{"cycle": "us06", "start_s": 590}, {"cycle": "hwfet", "start_s": 750}])
    assert [c.name for c in vec.cycles] == ["us06", "hwfet"]
    a = np.zeros((2, 1), np.float32)
    truncs = [vec.step(a)[3].copy() for _ in range(10)]
    assert truncs[9].tolist() == [True, False]
    with pytest.raises(RuntimeError, match="reset_mask"):
        vec.step(a)
    obs, info = vec.reset(options={"reset_mask": np.array([True, False])})
    assert info["_cycle_id"].tolist() == [True, False] and vec.k.tolist() == [0, 760]
    truncs = [vec.step(a)[3].copy() for _ in range(5)]
    assert truncs[4].tolist() == [False, True]


def test_infos_are_dicts_of_arrays_with_masks():
    vec = HevThermalVectorEnv(5, scenario="hot")
    _, info = vec.reset(seed=0)
    for key in INFO_KEYS:
        assert info[key].shape == (5,) and info["_" + key].all()
    _, rew, term, trunc, info = vec.step(np.full((5, 1), 0.7, np.float32))
    assert rew.dtype == np.float64 and term.dtype == trunc.dtype == np.bool_
    for key in INFO_KEYS:
        assert info[key].shape == (5,) and info["_" + key].dtype == np.bool_ and info["_" + key].all()
    assert info["engine_on"].dtype == np.bool_ and info["gear"].dtype == np.int64
    np.testing.assert_allclose(info["motor_speed_rpm"], vec.last_out[:, core.MOTOR_SPEED] * 30 / np.pi)


def test_seed_int_and_list_agree_and_attributes():
    a = HevThermalVectorEnv(3, **RANDOM_KW)
    b = HevThermalVectorEnv(3, **RANDOM_KW)
    oa, _ = a.reset(seed=5)
    ob, _ = b.reset(seed=[5, 6, 7])
    np.testing.assert_array_equal(oa, ob)
    assert not np.array_equal(oa[0], oa[1])
    assert a.phys_state.shape == (3, core.N_STATE) and a.cond.shape == (3, core.N_COND)
    assert a.last_out.shape == (3, core.N_OUT) and a.soc_target.shape == (3,)
    assert [c.initial_soc for c in a.conditions] == a.soc_target.tolist()
    assert a.get_attr("k") == tuple(a.k.tolist())
    assert a.get_attr("config") == (a.config,) * 3
    a.set_attr("reward_params", RewardParams(cutoff_weight=1.0))
    assert a.reward_params.cutoff_weight == 1.0
    with pytest.raises(ValueError):
        a.set_attr("cycle", None)


def test_bad_actions_raise():
    vec = HevThermalVectorEnv(4)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"\(4, 1\)"):
        vec.step(np.zeros(4, np.float32))
    with pytest.raises(ValueError, match=r"\(4, 1\)"):
        vec.step(np.zeros((3, 1), np.float32))
    bad = np.zeros((4, 1), np.float32)
    bad[2] = np.nan
    with pytest.raises(ValueError, match="finite"):
        vec.step(bad)
    clipped = vec.step(np.full((4, 1), 3.0, np.float32))[4]
    assert clipped["motor_share_clipped"].all() and (clipped["motor_share"] == 1.0).all()


def test_observations_inside_bounds():
    vec = HevThermalVectorEnv(16, max_episode_steps=200, **RANDOM_KW)
    obs, _ = vec.reset(seed=1)
    space = vec.observation_space
    for actions in actions_for(16, 300, seed=9):
        assert space.contains(obs)
        obs, *_ = vec.step(actions)


def test_unknown_reset_option_and_render():
    vec = HevThermalVectorEnv(2)
    with pytest.raises(ValueError, match="valid options"):
        vec.reset(options={"speed": 1})
    with pytest.raises(ValueError):
        HevThermalVectorEnv(2, render_mode="rgb_array")


# --- Stable-Baselines3 ------------------------------------------------------------------------------

def test_sb3_adapter_matches_dummy_vec_env():
    n, max_steps = 3, 15
    kw = dict(RANDOM_KW, max_episode_steps=max_steps)
    ours = Sb3VecEnv(n, **kw)
    ref = DummyVecEnv([lambda: gym.make("HevThermal-v2", **kw) for _ in range(n)])
    ours.seed(21)
    ref.seed(21)
    np.testing.assert_array_equal(ours.reset(), ref.reset())
    for i in range(n):
        assert ours.reset_infos[i] == ref.reset_infos[i]
    n_done = 0
    for actions in actions_for(n, 40, seed=4):
        o1, r1, d1, i1 = ours.step(actions)
        o2, r2, d2, i2 = ref.step(actions)
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        assert r1.dtype == r2.dtype and o1.dtype == o2.dtype
        for a, b in zip(i1, i2):
            assert a.keys() == b.keys()
            for key in a:
                if key == "terminal_observation":
                    np.testing.assert_array_equal(a[key], b[key])
                else:
                    assert a[key] == b[key], key
        for i in np.flatnonzero(d1):
            n_done += 1
            assert i1[i]["TimeLimit.truncated"] and ours.reset_infos[i] == ref.reset_infos[i]
    assert n_done >= n


def test_sb3_adapter_attrs_methods_and_info_keys():
    env = Sb3VecEnv(2, cycle="hwfet", info_keys=("fuel_g", "soc"))
    env.seed(0)
    env.reset()
    _, _, _, infos = env.step(np.zeros((2, 1), np.float32))
    assert set(infos[0]) == {"fuel_g", "soc", "TimeLimit.truncated"}
    assert env.get_attr("render_mode") == [None, None]
    assert [c.name for c in env.get_attr("cycle", indices=[1])] == ["hwfet"]
    assert env.get_attr("k") == [1, 1]
    env.set_attr("reward_params", RewardParams(fuel_weight=3.0))
    assert env.get_attr("reward_params")[0].fuel_weight == 3.0
    with pytest.raises(ValueError):
        env.set_attr("reward_params", RewardParams(), indices=[0])
    assert env.env_method("get_attr", "k", indices=0) == [(1, 1)]
    assert env.env_is_wrapped(gym.Wrapper) == [False, False]
    with pytest.raises(ValueError, match="info_keys"):
        Sb3VecEnv(2, info_keys=("nope",))


@pytest.mark.filterwarnings("ignore::hev_thermal_env.cycles.ImplausibleCycleWarning")  # US06: 3.8 m/s²
def test_sb3_ppo_learns_on_the_batched_core():
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from hev_thermal_env import cycle_from_arrays, load_cycle

    short = cycle_from_arrays(load_cycle("us06").speed_mps[:100], name="us06_first_100s")
    env = VecMonitor(Sb3VecEnv(4, cycle=short, scenario="random", random_start=True, info_keys=()))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu")
        model.learn(total_timesteps=512)
    assert len(model.ep_info_buffer) > 0  # episodes ended, were reset and recorded
    action, _ = model.predict(env.reset(), deterministic=True)
    assert action.shape == (4, 1)


# --- generic vectorisers over single envs -------------------------------------------------------------

@pytest.mark.parametrize("mode", ["sync", "async"])
def test_gymnasium_make_vec(mode):
    n = 2
    envs = gym.make_vec("HevThermal-v2", num_envs=n, vectorization_mode=mode, cycle="us06", scenario="random")
    try:
        obs, _ = envs.reset(seed=3)
        vec = HevThermalVectorEnv(n, cycle="us06", scenario="random")
        obs_native, _ = vec.reset(seed=3)
        np.testing.assert_array_equal(obs, obs_native)
        for actions in actions_for(n, 5):
            obs, rew, term, trunc, info = envs.step(actions)
            obs_native, rew_native, *_ = vec.step(actions)
            np.testing.assert_array_equal(obs, obs_native)
            np.testing.assert_array_equal(rew, rew_native)
        assert info["fuel_g"].shape == (n,)
    finally:
        envs.close()


@pytest.mark.full
def test_sb3_subproc_vec_env():
    env = SubprocVecEnv([lambda: gym.make("hev_thermal_env:HevThermal-v2", cycle="us06") for _ in range(2)])
    try:
        env.seed(0)
        obs = env.reset()
        assert obs.shape == (2, 21)
        obs, rew, done, infos = env.step(np.full((2, 1), 0.3, np.float32))
        assert rew.shape == (2,) and "fuel_g" in infos[0]
    finally:
        env.close()


def test_vector_entry_point_and_gymnasium_vector_wrappers():
    from gymnasium.wrappers.vector import NormalizeObservation, RecordEpisodeStatistics

    env_id = "HevThermalNativeVecCheck-v0"
    if env_id not in gym.registry:
        gym.register(env_id, entry_point="hev_thermal_env.envs.hev_env:HevThermalEnv",
                     vector_entry_point="hev_thermal_env.envs.vector_env:HevThermalVectorEnv")
    envs = gym.make_vec(env_id, num_envs=3, cycle="us06", random_start=True)
    assert isinstance(envs.unwrapped, HevThermalVectorEnv) and envs.unwrapped.spec.id == env_id
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        envs = RecordEpisodeStatistics(NormalizeObservation(envs))
        envs.reset(seed=0)
        episodes = 0
        for actions in actions_for(3, 700):
            *_, info = envs.step(actions)
            episodes += int(info["_episode"].sum()) if "episode" in info else 0
    assert episodes >= 3
