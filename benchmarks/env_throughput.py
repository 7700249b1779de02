"""Throughput of HevThermal-v1: single env, native vector env, SB3 adapter, and Pendulum-v1 for reference.

Measures, in one run on the same machine:

* ``single_env``: steps/s of one ``gymnasium.make("HevThermal-v1")`` env (with gymnasium's default
  wrappers: PassiveEnvChecker, OrderEnforcing), reset at truncation, and its ratio to Pendulum-v1
  in the same run. Target ≥ 1.0×.
* ``pendulum_reference``: steps/s of ``gymnasium.make("Pendulum-v1")``, the same loop.
* ``vector_env``: env-steps/s of :class:`HevThermalVectorEnv` with ``--num-envs`` (1024) sub-envs
  in the default configuration (HWFET, ``paper`` scenario), autoreset included (all sub-envs end
  together every 765 steps). Target ≥ 3 000 000.
* ``vector_env_training``: the same with a training-like configuration (``random`` scenario,
  ``random_start``, HWFET/UDDS/US06): episodes end at different steps, so a few sub-envs reset in
  almost every step.
* ``sb3_adapter``: env-steps/s of :class:`Sb3VecEnv` with full per-env infos and with
  ``info_keys=()`` (what PPO needs).
* ``sync_vector_env``: env-steps/s of ``gymnasium.make_vec("HevThermal-v1", 8,
  vectorization_mode="sync")`` (gymnasium's ``SyncVectorEnv`` over 8 single envs, which merges every
  info key of every sub-env at every step) with all infos and with ``info_keys=()``, beside one env
  (``single_env`` and ``single_env_no_infos``) in the same run: each figure is the best of
  ``--repeats`` interleaved runs, so that a busy machine slows every variant alike.
* ``physics_kernel``: the batched physics step alone at the same batch size, for context.

Usage::

    python benchmarks/env_throughput.py                # full run, writes benchmarks/results/env_throughput.json
    python benchmarks/env_throughput.py --quick        # a tiny run (seconds)
    python benchmarks/env_throughput.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hev_thermal_env  # noqa: E402  (registers HevThermal-v1)
from hev_thermal_env.envs import HevThermalVectorEnv  # noqa: E402
from hev_thermal_env.physics.core import N_OUT, N_STATE  # noqa: E402
from hev_thermal_env.wrappers.sb3 import Sb3VecEnv  # noqa: E402

TARGET_PENDULUM_RATIO = 1.0  # one env at least as fast as Pendulum-v1 in the same run
TARGET_VECTOR = 3_000_000.0
DEFAULT_JSON = Path(__file__).resolve().parent / "results" / "env_throughput.json"


def single_env_rate(env_id: str, n_steps: int, seed: int = 0, **kwargs) -> dict:
    env = gym.make(env_id, **kwargs)
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n_steps, 1)).astype(np.float32)
    if env_id.startswith("Pendulum"):
        actions *= 2.0
    env.reset(seed=seed)
    for a in actions[: min(200, n_steps)]:  # warm-up (numba dispatch, checker's first-step checks)
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for a in actions:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    wall = time.perf_counter() - t0
    env.close()
    return {"steps": n_steps, "wall_s": wall, "steps_per_s": n_steps / wall}


def sync_vector_rate(num_envs: int, n_steps: int, seed: int = 0, **kwargs) -> dict:
    envs = gym.make_vec("HevThermal-v1", num_envs, vectorization_mode="sync", **kwargs)
    envs.reset(seed=seed)
    wall, _ = timed_steps(envs, num_envs, n_steps, warmup=50, seed=seed)
    envs.close()
    return {"num_envs": num_envs, "vector_steps": n_steps, "env_steps": n_steps * num_envs, "wall_s": wall,
            "env_steps_per_s": n_steps * num_envs / wall}


def timed_steps(envs, num_envs: int, n_steps: int, warmup: int, seed: int = 0) -> tuple[float, int]:
    """Wall time of ``n_steps`` steps of a vector env after ``warmup`` steps, and the episodes ended meanwhile."""
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(8, num_envs, 1)).astype(np.float32)
    for i in range(warmup):
        envs.step(actions[i % 8])
    ended = 0
    t0 = time.perf_counter()
    for i in range(n_steps):
        ended += int(np.sum(envs.step(actions[i % 8])[3]))
    return time.perf_counter() - t0, ended


def best_of(repeats: int, runs: dict) -> dict:
    """Each of ``runs`` (name -> no-argument callable returning a dict with a rate) run ``repeats`` times,
    interleaved; the run with the highest rate of each."""
    best: dict[str, dict] = {}
    for _ in range(repeats):
        for name, run in runs.items():
            r = run()
            rate = r.get("steps_per_s", r.get("env_steps_per_s"))
            if name not in best or rate > best[name].get("steps_per_s", best[name].get("env_steps_per_s")):
                best[name] = r
    return {name: {**r, "repeats": repeats} for name, r in best.items()}


def vector_rate(num_envs: int, n_steps: int, seed: int = 0, **kwargs) -> dict:
    envs = HevThermalVectorEnv(num_envs, **kwargs)
    envs.reset(seed=seed)
    wall, resets = timed_steps(envs, num_envs, n_steps, warmup=20, seed=seed)
    return {"num_envs": num_envs, "vector_steps": n_steps, "env_steps": n_steps * num_envs, "wall_s": wall,
            "env_steps_per_s": n_steps * num_envs / wall, "episodes_ended": resets}


def sb3_rate(num_envs: int, n_steps: int, info_keys, seed: int = 0) -> dict:
    env = Sb3VecEnv(num_envs, cycle="hwfet", random_start=True, info_keys=info_keys)
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(8, num_envs, 1)).astype(np.float32)
    env.seed(seed)
    env.reset()
    for i in range(5):
        env.step(actions[i % 8])
    t0 = time.perf_counter()
    for i in range(n_steps):
        env.step(actions[i % 8])
    wall = time.perf_counter() - t0
    return {"num_envs": num_envs, "info_keys": "all" if info_keys == "all" else list(info_keys),
            "vector_steps": n_steps, "env_steps": n_steps * num_envs, "wall_s": wall,
            "env_steps_per_s": n_steps * num_envs / wall}


def kernel_rate(num_envs: int, n_steps: int) -> dict:
    envs = HevThermalVectorEnv(num_envs, cycle="hwfet", random_start=True)
    envs.reset(seed=0)
    rows = envs._rows
    core = envs.core
    r, k = rows.all_rows, rows.k
    v0, v1, g = rows.speed[r, k], rows.speed[r, k + 1], rows.grade[r, k]
    u = np.full(num_envs, 0.3)
    st_out = np.empty((num_envs, N_STATE))
    out = np.empty((num_envs, N_OUT))
    kwargs = dict(state_out=st_out, out=out)
    core.step(rows.state, u, v0, v1, g, rows.cond, **kwargs)
    t0 = time.perf_counter()
    for _ in range(n_steps):
        core.step(rows.state, u, v0, v1, g, rows.cond, **kwargs)
    wall = time.perf_counter() - t0
    return {"num_envs": num_envs, "calls": n_steps, "wall_s": wall, "env_steps_per_s": n_steps * num_envs / wall,
            "us_per_call": wall / n_steps * 1e6}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, default=DEFAULT_JSON, help=f"output file (default {DEFAULT_JSON})")
    parser.add_argument("--quick", action="store_true", help="a tiny run to check the script (numbers are rough)")
    parser.add_argument("--num-envs", type=int, default=1024, help="sub-environments of the vector runs")
    parser.add_argument("--sync-envs", type=int, default=8, help="sub-environments of the SyncVectorEnv runs")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved repeats of the single/sync runs")
    args = parser.parse_args(argv)

    n_single = 2_000 if args.quick else 50_000
    n_vector = 20 if args.quick else 1_600
    n_sb3 = 10 if args.quick else 200

    t_import = time.perf_counter()
    n_sync = max(n_single // args.sync_envs, 50)
    best = best_of(args.repeats, {
        "single": lambda: single_env_rate("HevThermal-v1", n_single, cycle="hwfet"),
        "single_lean": lambda: single_env_rate("HevThermal-v1", n_single, cycle="hwfet", info_keys=()),
        "sync": lambda: sync_vector_rate(args.sync_envs, n_sync, cycle="hwfet"),
        "sync_lean": lambda: sync_vector_rate(args.sync_envs, n_sync, cycle="hwfet", info_keys=()),
    })
    single = best["single"]
    pendulum = single_env_rate("Pendulum-v1", n_single)
    ratio = single["steps_per_s"] / pendulum["steps_per_s"]
    results = {
        "single_env": {**single, "ratio_to_pendulum": ratio, "target_ratio_to_pendulum": TARGET_PENDULUM_RATIO,
                       "meets_target": ratio >= TARGET_PENDULUM_RATIO},
        "pendulum_reference": pendulum,
        "single_env_no_infos": best["single_lean"],
        "sync_vector_env": {"all_infos": best["sync"], "no_infos": best["sync_lean"],
                            "ratio_to_single_env": {
                                "all_infos": best["sync"]["env_steps_per_s"] / single["steps_per_s"],
                                "no_infos": best["sync_lean"]["env_steps_per_s"] / single["steps_per_s"]}},
    }
    vec = vector_rate(args.num_envs, n_vector, cycle="hwfet")
    results["vector_env"] = {**vec, "target_env_steps_per_s": TARGET_VECTOR,
                             "meets_target": vec["env_steps_per_s"] >= TARGET_VECTOR}
    results["vector_env_training"] = vector_rate(args.num_envs, n_vector, cycle=["hwfet", "udds", "us06"],
                                                 scenario="random", random_start=True)
    results["sb3_adapter"] = sb3_rate(args.num_envs, n_sb3, "all")
    results["sb3_adapter_no_infos"] = sb3_rate(args.num_envs, n_sb3, ())
    results["physics_kernel"] = kernel_rate(args.num_envs, n_vector)
    results["meta"] = {
        "quick": args.quick, "python": platform.python_version(), "numpy": np.__version__,
        "numba": numba.__version__, "gymnasium": gym.__version__, "hev_thermal_env": hev_thermal_env.__version__,
        "machine": platform.machine(), "cpu_count": os.cpu_count(), "total_wall_s": time.perf_counter() - t_import,
        "load_average_1min_at_end": os.getloadavg()[0],  # other work on the machine slows every figure
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=2) + "\n")

    print(f"single env (gymnasium.make)   {results['single_env']['steps_per_s']:>14,.0f} steps/s "
          f"({ratio:.2f}x Pendulum-v1, target {TARGET_PENDULUM_RATIO:.1f}x)")
    print(f"Pendulum-v1 (reference)       {results['pendulum_reference']['steps_per_s']:>14,.0f} steps/s")
    print(f"single env, info_keys=()      {best['single_lean']['steps_per_s']:>14,.0f} steps/s")
    print(f"SyncVectorEnv x{args.sync_envs}, all infos  {best['sync']['env_steps_per_s']:>14,.0f} env-steps/s")
    print(f"SyncVectorEnv x{args.sync_envs}, info_keys=() {best['sync_lean']['env_steps_per_s']:>13,.0f} env-steps/s")
    print(f"vector env, {args.num_envs} envs        {vec['env_steps_per_s']:>14,.0f} env-steps/s "
          f"(target {TARGET_VECTOR:,.0f})")
    print(f"vector env, training config   {results['vector_env_training']['env_steps_per_s']:>14,.0f} env-steps/s")
    print(f"SB3 adapter, all infos        {results['sb3_adapter']['env_steps_per_s']:>14,.0f} env-steps/s")
    print(f"SB3 adapter, info_keys=()     {results['sb3_adapter_no_infos']['env_steps_per_s']:>14,.0f} env-steps/s")
    print(f"physics kernel alone          {results['physics_kernel']['env_steps_per_s']:>14,.0f} env-steps/s")
    print(f"wrote {args.json}")
    return results


if __name__ == "__main__":
    main()
