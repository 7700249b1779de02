#!/usr/bin/env python
"""Import-to-first-step time of ``HevThermal-v1`` in a fresh process, without and with the compiled cache.

Each measurement runs a new Python process that imports the package, makes the env, resets it and
takes one step. ``no_cache`` uses an empty cache directory (every kernel is compiled); ``cached``
runs again with the cache the first run left. Writes JSON (default
``benchmarks/results/cold_start.json``). Target: cached ≤ 2 s.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

PROBE = """
import time
t0 = time.perf_counter()
import gymnasium as gym
import numpy as np
import hev_thermal_env
env = gym.make("HevThermal-v1")
env.reset(seed=0)
env.step(np.zeros(1, dtype=np.float32))
print(time.perf_counter() - t0)
"""
TARGET_CACHED_S = 2.0
ROOT = Path(__file__).resolve().parents[1]


def first_step_s(cache_dir: str) -> float:
    env = dict(os.environ, HEV_THERMAL_ENV_CACHE_DIR=cache_dir)
    res = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, check=True,
                         cwd=ROOT)
    return float(res.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results" / "cold_start.json")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    no_cache, cached = [], []
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory() as tmp:
            no_cache.append(first_step_s(tmp))
            cached.append(first_step_s(tmp))
    results = {"no_cache_s": min(no_cache), "cached_s": min(cached), "runs_no_cache_s": no_cache,
               "runs_cached_s": cached, "target_cached_s": TARGET_CACHED_S,
               "meets_target": min(cached) <= TARGET_CACHED_S, "cpu_count": os.cpu_count()}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=2) + "\n")
    print(f"import to first step: {results['no_cache_s']:.2f} s without a cache, {results['cached_s']:.2f} s cached "
          f"(target {TARGET_CACHED_S:.1f} s); wrote {args.json}")
    return results


if __name__ == "__main__":
    main()
