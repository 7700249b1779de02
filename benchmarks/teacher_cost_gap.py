#!/usr/bin/env python
"""How much a policy loses to its teacher, by the teacher's own measure (docs/training.md, "Charging the teacher's own
cost").

Each policy (``--policy NAME=RUN_DIR_OR_ZIP``, a ``train.py`` run) and its teacher (``ecms_thermal`` with the options
the policies were fitted to, or ``--teacher-options``: ``policy_teacher.py``) drive each ``--run CYCLE/SCENARIO``
(default: ``hwfet`` and ``beijing`` in ``paper``, ``udds`` in ``summer``, ``validation_bus:21`` in ``paper``). Per
run: the episode's fuel, its reward's miss and SOC terms, the missed wheel energy, the safety cost and the final SOC.
While a policy drives, the teacher also prices every state it visits (its ``cost_curve_g``): the excess of the
policy's action over the teacher's cheapest candidate there, summed over the run (g), in traction and braking apart.
That sum is the gap a fit to the teacher's actions leaves; the teacher's own is 0 by construction.

Writes JSON (default ``benchmarks/results/teacher_cost_gap.json``); about 5 s for two policies::

    PYTHONPATH=. python benchmarks/teacher_cost_gap.py \\
        --policy "previous default=runs/learned/ppo_heat_weight/seed_0" \\
        --policy "default=runs/learned/ppo_cost_weight/seed_0"
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]
import policy_teacher  # noqa: E402 - the benchmark's own folder

RUNS = ("hwfet/paper", "beijing/paper", "udds/summer", "validation_bus:21/paper")
TOTALS = ("fuel_g", "reward_miss", "reward_soc", "missed_wheel_energy_j", "cost")


def drive(strategy: Any, teacher: Any, cycle: str, scenario: str) -> dict[str, Any]:
    """One run of ``strategy`` (the env it asks for) with ``teacher`` pricing each state it visits."""
    from hev_thermal_env.cycles import load_cycle
    from hev_thermal_env.envs import HevThermalEnv
    from hev_thermal_env.physics import core as C

    env = HevThermalEnv(cycle=load_cycle(cycle), scenario=scenario, **strategy.env_options())
    try:
        obs, info = env.reset(seed=0)
        strategy.reset(env)
        teacher.reset(env)
        totals = dict.fromkeys(TOTALS, 0.0)
        excess = {"traction": 0.0, "braking": 0.0}
        grid = teacher.u_grid
        done = False
        while not done:
            demand = float(env.peek(np.zeros(1))[1][0, C.SHAFT_DEMAND])
            action = np.asarray(strategy.act(obs, info), dtype=np.float64).reshape(1)
            teacher.act(obs, info)
            if demand != 0.0:
                u = float(np.clip(action[0], -1.0, 1.0))
                excess["traction" if demand > 0.0 else "braking"] += float(np.interp(u, grid, teacher.cost_curve_g))
            obs, _, terminated, truncated, info = env.step(action.astype(np.float32))
            for key in TOTALS:
                totals[key] += float(info[key])
            done = terminated or truncated
        soc = float(env.phys_state[0, C.SOC])
    finally:
        env.close()
    return {**{k: round(v, 3) for k, v in totals.items()}, "soc_final": round(soc, 5),
            "excess_g": {k: round(v, 3) for k, v in excess.items()}}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    policy_teacher.add_arguments(p)
    p.add_argument("--run", action="append", default=None, metavar="CYCLE/SCENARIO", help="repeatable")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "teacher_cost_gap.json"), metavar="FILE")
    args = p.parse_args(argv)
    policies = policy_teacher.named_policies(args)
    runs = [r.rpartition("/")[::2] for r in (args.run or RUNS)]
    if any(not cycle or not scenario for cycle, scenario in runs):
        raise SystemExit(f"--run must be CYCLE/SCENARIO, got {args.run}")
    given = policy_teacher.given_options(args)

    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.io import atomic_write_json

    t0 = time.perf_counter()
    strategies = {name: get_strategy(f"ppo:{path}") for name, path in policies}
    options = policy_teacher.teacher_options(given, strategies)

    def teacher() -> Any:
        return get_strategy(policy_teacher.TEACHER, **options)

    record: dict[str, Any] = {"teacher_options": options, "runs": {}}
    for cycle, scenario in runs:
        rows: dict[str, Any] = {}
        for name, strategy in [("teacher", teacher()), *strategies.items()]:
            rows[name] = drive(strategy, teacher(), cycle, scenario)
            print(f"{cycle}/{scenario} {name}: {rows[name]}", flush=True)
        record["runs"][f"{cycle}/{scenario}"] = rows
    record["policies"] = dict(policies)
    record["wall_s"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(args.out, record)
    print(f"wrote {args.out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
