"""The env, unmodified, under the libraries RL researchers use: torchrl (single and batched), sb3-contrib,
fresh worker processes (the ``module:Id`` form), gymnasium's vector wrappers on the lean info path. The info's
contract (numpy values, the same keys at resets and steps; torchrl's info reader on the single env, Minari):
tests/test_info_contract.py."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import hev_thermal_env
from hev_thermal_env import load_cycle
from hev_thermal_env.envs.spaces import coolant_mode, cycle_name
from hev_thermal_env.physics.config import COOLANT_MODES

torchrl_gym = pytest.importorskip("torchrl.envs.libs.gym")  # the [dev] extra installs it
check_env_specs = pytest.importorskip("torchrl.envs.utils").check_env_specs

ROOT = Path(__file__).resolve().parents[1]
SAME_STEP = AutoresetMode.SAME_STEP


@pytest.fixture(scope="module")
def short_cycle(tmp_path_factory) -> str:
    """A 41 s slice of UDDS, so that rollouts cross episode ends (autoreset) quickly."""
    path = tmp_path_factory.mktemp("compat") / "udds_41s.csv"
    v = load_cycle("udds").speed_mps[20:61]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return str(path)


# --- what any library can rely on -------------------------------------------------------------------------

def test_codes_and_their_lookups():
    assert [cycle_name(i) for i in range(len(hev_thermal_env.list_cycles()))] == hev_thermal_env.list_cycles()
    assert [coolant_mode(i) for i in range(3)] == list(COOLANT_MODES)
    with pytest.raises(KeyError, match="cycle id 99999 is not known in this process"):
        cycle_name(99999)
    with pytest.raises(KeyError, match="coolant code 7"):
        coolant_mode(7)


def test_an_all_zero_observation_is_inside_the_space():
    for space in (gym.make("HevThermal-v2").observation_space,
                  hev_thermal_env.HevThermalVectorEnv(2).single_observation_space):
        assert np.zeros(space.shape, np.float32) in space
        assert space.low[hev_thermal_env.envs.HevThermalEnv(cycle="hwfet").obs_names.index("gear")] == 0.0


def test_the_envs_are_reachable_from_the_package():
    assert hev_thermal_env.HevThermalEnv is hev_thermal_env.envs.HevThermalEnv
    assert hev_thermal_env.HevThermalVectorEnv is hev_thermal_env.envs.vector_env.HevThermalVectorEnv
    from hev_thermal_env import HevThermalVectorEnv

    assert HevThermalVectorEnv(2).reset(seed=0)[0].shape == (2, 21)


def test_module_id_form_makes_the_env_in_a_fresh_process():
    """A worker that never imported the package (RLlib's remote runners): the bare id is unknown there,
    ``hev_thermal_env:HevThermal-v2`` imports the package and makes the env; ``gym.spec`` takes no such form, the
    bare id after the import."""
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'hev_thermal_env' not in sys.modules\n"
        "try:\n"
        "    gym.make('HevThermal-v2')\n"
        "except gym.error.NameNotFound:\n"
        "    print('bare id: NameNotFound')\n"
        "env = gym.make('hev_thermal_env:HevThermal-v2', cycle='udds')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(obs.shape, env.spec.id, sorted(info)[:2])\n"
        "envs = gym.make_vec('hev_thermal_env:HevThermal-v2', 3)\n"
        "print(type(envs).__name__, envs.reset(seed=0)[0].shape)\n"
        "try:\n"
        "    gym.spec('hev_thermal_env:HevThermal-v2')\n"
        "except gym.error.NameNotFound:\n"
        "    print('spec of module:Id: NameNotFound;', 'spec of the bare id:', gym.spec('HevThermal-v2').id)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300,
                       env={**_clean_env(), "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["bare id: NameNotFound",
                                     "(21,) HevThermal-v2 ['ambient_temp_c', 'battery_chem_power_w']",
                                     "HevThermalVectorEnv (3, 21)",
                                     "spec of module:Id: NameNotFound; spec of the bare id: HevThermal-v2"]


def _clean_env() -> dict:
    import os

    return {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


# --- the lean info path -----------------------------------------------------------------------------------

def test_info_keys_choose_the_keys_of_every_info():
    lean = gym.make("HevThermal-v2", info_keys=())
    assert lean.reset(seed=0)[1] == {} and lean.step(np.zeros(1, np.float32))[4] == {}
    some = gym.make("HevThermal-v2", info_keys=("fuel_g", "cycle_id"))
    assert some.reset(seed=0)[1] == {"fuel_g": 0.0, "cycle_id": 0}
    assert tuple(some.step(np.zeros(1, np.float32))[4]) == ("fuel_g", "cycle_id")
    full = gym.make("HevThermal-v2")
    full.reset(seed=0)
    assert full.step(np.zeros(1, np.float32))[4]["fuel_g"] == lean_fuel(some)
    with pytest.raises(ValueError, match=r"info_keys: unknown key\(s\) \['action'\]"):
        gym.make("HevThermal-v2", info_keys=("action",))
    with pytest.raises(ValueError, match="info_keys: 'all' or a sequence"):
        gym.make("HevThermal-v2", info_keys="some")


def lean_fuel(env: gym.Env) -> float:
    env.reset(seed=0)
    return env.step(np.zeros(1, np.float32))[4]["fuel_g"]


def test_sync_vector_env_on_the_lean_path_matches_the_native_vector_env():
    acts = np.random.default_rng(0).uniform(-1, 1, (900, 3, 1)).astype(np.float32)
    sync = gym.make_vec("HevThermal-v2", 3, vectorization_mode="sync", info_keys=(), cycle="udds")
    native = gym.make_vec("HevThermal-v2", 3, info_keys=(), cycle="udds")
    assert type(sync).__name__ == "SyncVectorEnv" and type(native).__name__ == "HevThermalVectorEnv"
    o1, i1 = sync.reset(seed=5)
    o2, i2 = native.reset(seed=5)
    assert i1 == {} and i2 == {}
    for a in acts:
        s1, s2 = sync.step(a), native.step(a)
        np.testing.assert_array_equal(s1[0], s2[0])
        np.testing.assert_array_equal(s1[1], s2[1])
        assert s1[4] == {} and s2[4] == {}


# --- torchrl ----------------------------------------------------------------------------------------------



def _torchrl_quiet():
    warnings.filterwarnings("ignore", category=UserWarning)
    warnings.filterwarnings("ignore", category=DeprecationWarning)


def test_torchrl_single_env(short_cycle):
    _torchrl_quiet()
    env = torchrl_gym.GymWrapper(gym.make("HevThermal-v2", cycle=short_cycle))
    check_env_specs(env)
    td = env.rollout(100, break_when_any_done=False)  # torchrl resets at each of the two episode ends
    assert td.shape == (100,) and td["next", "truncated"].sum().item() == 2
    check_env_specs(torchrl_gym.GymEnv("HevThermal-v2", cycle=short_cycle))
    # infos as tensors through a batch of one (the single env's infos: tests/test_info_contract.py)
    one = torchrl_gym.GymWrapper(gym.make_vec("HevThermal-v2", 1, autoreset_mode=SAME_STEP, cycle=short_cycle))
    check_env_specs(one)
    td = one.rollout(50, break_when_any_done=False)
    assert {"fuel_g", "motor_share", "cycle_id", "coolant_code"} <= set(td["next"].keys())


@pytest.mark.parametrize("mode", ["sync", "native"])
@pytest.mark.parametrize("info_keys", ["all", ()], ids=["all_infos", "no_infos"])
def test_torchrl_batched_env(short_cycle, mode, info_keys):
    """torchrl needs the SAME_STEP (or DISABLED) autoreset mode; it fills the final observation with zeros and
    reads every info key of the batch into fixed specs."""
    _torchrl_quiet()
    if mode == "sync":
        venv = gym.make_vec("HevThermal-v2", 3, vectorization_mode="sync", vector_kwargs={"autoreset_mode": SAME_STEP},
                            cycle=short_cycle, scenario="random", info_keys=info_keys)
    else:
        venv = gym.make_vec("HevThermal-v2", 3, autoreset_mode=SAME_STEP, cycle=short_cycle, scenario="random",
                            info_keys=info_keys)
    env = torchrl_gym.GymWrapper(venv)
    check_env_specs(env)
    td = env.rollout(100, break_when_any_done=False)
    assert td.shape == (3, 100) and td["next", "truncated"].sum().item() == 6
    obs = td["next", "observation"]
    assert torch_all_finite(obs)
    if info_keys == "all":
        assert td["next", "motor_share"].shape == (3, 100) and td["next", "fuel_g"].min().item() >= 0.0
        assert td["next", "motor_share"].abs().max().item() <= 1.0


def torch_all_finite(t) -> bool:
    import torch

    return bool(torch.isfinite(t).all())


# --- sb3-contrib ------------------------------------------------------------------------------------------

@pytest.mark.full
def test_sb3_contrib_recurrent_ppo_and_tqc_train(short_cycle):
    import sb3_contrib
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: gym.make("HevThermal-v2", cycle=short_cycle) for _ in range(2)])
    rppo = sb3_contrib.RecurrentPPO("MlpLstmPolicy", venv, n_steps=64, batch_size=64, n_epochs=1, seed=0,
                                    policy_kwargs={"lstm_hidden_size": 16, "net_arch": [16]}, device="cpu")
    rppo.learn(256)
    assert rppo.num_timesteps == 256
    tqc = sb3_contrib.TQC("MlpPolicy", gym.make("HevThermal-v2", cycle=short_cycle), learning_starts=100,
                          batch_size=32, buffer_size=1000, seed=0, device="cpu",
                          policy_kwargs={"net_arch": [32, 32], "n_critics": 2})
    tqc.learn(300)
    assert tqc.num_timesteps == 300
    action, _ = tqc.predict(np.zeros(21, np.float32), deterministic=True)
    assert action.shape == (1,) and -1.0 <= float(action[0]) <= 1.0
