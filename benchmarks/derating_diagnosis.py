#!/usr/bin/env python
"""Where a policy derates, and how closely its fit follows the teacher there (docs/training.md, "Fitting the teacher
where the motor derates").

Two measurements per policy (``--policy NAME=RUN_DIR_OR_ZIP``, a ``train.py`` run) and for the teacher
(``ecms_thermal`` with the options the policies were fitted to, or ``--teacher-options``: ``policy_teacher.py``):

* on one selection route and scenario (``--cycle``, ``--scenario``; default ``validation_bus:25`` in ``hilly``, the
  motorway route where the previous default derated most): the safety cost (s of lost motor capability), the motor's
  peak temperature, and the share of the steps in which the heat-index integrator x rises that are braking (motor
  torque below 0: regeneration);
* on ``--episodes`` fresh teacher episodes of the policy's own training env (its ``config.yaml``; never a task's or
  validation cycle): the squared error of the policy's deterministic action to the teacher's, by band of x.

Writes JSON (default ``benchmarks/results/derating_diagnosis.json``); 11 s for four policies::

    PYTHONPATH=. python benchmarks/derating_diagnosis.py \\
        --policy "previous default=runs/learned/ppo_center_floor/seed_0" \\
        --policy "default=runs/learned/ppo_heat_weight/seed_0"
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import policy_teacher  # noqa: E402 - the benchmark's own folder

ROOT = Path(__file__).resolve().parents[1]
BANDS = ((-1.0, -0.2), (-0.2, -0.1), (-0.1, -0.05), (-0.05, 0.0), (0.0, 1.0))


def where_it_derates(strategy: Any, cycle: str, scenario: str) -> dict[str, Any]:
    """Safety cost, peak motor temperature and the braking share of the steps in which x rises, on one run."""
    from hev_thermal_env.evaluation.runner import run_strategy

    res = run_strategy(strategy, cycle, scenario, seed=0)
    x, torque = np.asarray(res.trace["heat_x"]), np.asarray(res.trace["motor_torque_nm"])
    n = min(len(x), len(torque))
    rising = np.diff(x[:n], prepend=x[0]) > 1e-6
    return {"safety_cost_s": float(res.summary["safety_cost_s"]),
            "motor_temp_max_c": float(np.max(res.trace["motor_temp_c"])),
            "x_rising_steps": int(rising.sum()),
            "x_rising_braking_share": float(np.mean(torque[:n][rising] < 0.0)) if rising.any() else None}


def fit_errors(act: Any, obs: np.ndarray, actions: np.ndarray) -> list[dict[str, Any]]:
    """Per band of x: its share of the states, the mean squared error to the teacher, both mean actions."""
    from hev_thermal_env.training.fit import heat_x

    x = heat_x(obs)
    student = np.asarray(act(obs)).reshape(-1)
    rows = []
    for lo, hi in BANDS:
        m = (x > lo) & (x <= hi)
        rows.append({"x_band": [lo, hi], "share": float(m.mean()),
                     "mse": float(np.mean((student[m] - actions[m]) ** 2)) if m.any() else None,
                     "teacher_mean": float(actions[m].mean()) if m.any() else None,
                     "student_mean": float(student[m].mean()) if m.any() else None})
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    policy_teacher.add_arguments(p)
    p.add_argument("--cycle", default="validation_bus:25")
    p.add_argument("--scenario", default="hilly")
    p.add_argument("--episodes", type=int, default=40, help="teacher episodes for the fit errors")
    p.add_argument("--seed", type=int, default=12345, help="seed of the teacher episodes")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "derating_diagnosis.json"), metavar="FILE")
    args = p.parse_args(argv)
    policies = policy_teacher.named_policies(args)
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be at least 1, got {args.episodes}")
    given = policy_teacher.given_options(args)

    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.io import atomic_write_json
    from hev_thermal_env.training.envs import env_kwargs
    from hev_thermal_env.training.imitation import demonstrations

    t0 = time.perf_counter()
    strategies = {name: get_strategy(f"ppo:{path}") for name, path in policies}
    options = policy_teacher.teacher_options(given, strategies)
    teacher = get_strategy(policy_teacher.TEACHER, **options)
    record: dict[str, Any] = {"cycle": args.cycle, "scenario": args.scenario, "teacher_options": options,
                              "episodes": args.episodes, "seed": args.seed,
                              "teacher": {"route": where_it_derates(teacher, args.cycle, args.scenario)},
                              "policies": {}}
    demos, env = None, None
    for name, path in policies:
        strategy = strategies[name]
        if env is None:  # the first policy's training env; every other policy must have trained on the same
            env = env_kwargs(strategy.policy.config["env"])
            demos = demonstrations(env, teacher, args.episodes, args.seed)
        elif env_kwargs(strategy.policy.config["env"]) != env:
            raise SystemExit(f"--policy {name}: trained on another env than {policies[0][0]}; compare them apart")
        record["policies"][name] = {"path": path, "route": where_it_derates(strategy, args.cycle, args.scenario),
                                    "fit": fit_errors(strategy.policy.act, *demos)}
        print(name, record["policies"][name]["route"], flush=True)
    record["wall_s"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(args.out, record)
    print(f"wrote {args.out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
