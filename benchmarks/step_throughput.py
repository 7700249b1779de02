#!/usr/bin/env python
"""Physics step throughput through ``PhysicsCore.step``: vehicle-steps per second at batch 1 and 4096, one core.

Writes JSON (default ``benchmarks/results/step_throughput.json``). Target: at least 10 million
vehicle-steps per second at batch 4096. The batch-1 figure includes the door's argument checks.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.physics import Conditions, PhysicsCore, core, paper_bus

TARGET = 10_000_000


def measure(batch: int, seconds: float) -> dict:
    phys = PhysicsCore(paper_bus())
    cyc = load_cycle("hwfet")
    cond_obj = Conditions()
    state = phys.initial_state(cond_obj, batch)
    st_out = np.empty_like(state)
    out = np.empty((batch, core.N_OUT))
    cond = phys.conditions_array(cond_obj, batch)
    rng = np.random.default_rng(0)
    action = rng.uniform(-1, 1, batch)
    v = np.asarray(cyc.speed_mps)
    n_steps = len(v) - 1
    v0s = [np.full(batch, v[k]) for k in range(n_steps)]
    v1s = [np.full(batch, v[k + 1]) for k in range(n_steps)]
    grade = np.zeros(batch)
    # warm-up (compilation)
    phys.step(state, action, v0s[0], v1s[0], grade, cond, state_out=st_out, out=out)
    steps = 0
    t0 = time.perf_counter()
    k = 0
    while True:
        phys.step(state, action, v0s[k], v1s[k], grade, cond, state_out=st_out, out=out)
        state, st_out = st_out, state
        k = (k + 1) % n_steps
        if k == 0:
            state = phys.initial_state(cond_obj, batch)
        steps += 1
        if steps % 64 == 0 and time.perf_counter() - t0 > seconds:
            break
    wall = time.perf_counter() - t0
    return {"batch": batch, "calls": steps, "wall_s": wall, "calls_per_s": steps / wall,
            "vehicle_steps_per_s": steps * batch / wall, "us_per_call": wall / steps * 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default="benchmarks/results/step_throughput.json")
    ap.add_argument("--seconds", type=float, default=3.0, help="measuring time per batch size")
    args = ap.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    results = {"batch_1": measure(1, args.seconds), "batch_4096": measure(4096, args.seconds)}
    results["target_batch_4096_vehicle_steps_per_s"] = TARGET
    results["target_met"] = results["batch_4096"]["vehicle_steps_per_s"] >= TARGET
    results["machine"] = {"python": platform.python_version(), "cpu_count": os.cpu_count(),
                          "processor": platform.processor() or platform.machine()}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    for key in ("batch_1", "batch_4096"):
        r = results[key]
        print(f"{key:>11}: {r['vehicle_steps_per_s']:>14,.0f} vehicle-steps/s  ({r['us_per_call']:.2f} µs per call)")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
