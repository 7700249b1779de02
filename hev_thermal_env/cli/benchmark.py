"""``evaluate.py benchmark``: strategies × cycles × scenarios, or a named task's cycles and scenario, a table and
plots (the main job)."""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import list_strategies
from hev_thermal_env.cycles import expand_cycle_names, list_cycles
from hev_thermal_env.evaluation.benchmark import (
    DEFAULT_CYCLES,
    DEFAULT_SCENARIOS,
    DEFAULT_STRATEGIES,
    run_benchmark,
)
from hev_thermal_env.evaluation.executors import EXECUTORS, ExecutorError
from hev_thermal_env.evaluation.families import MIN_SEEDS, parse_family
from hev_thermal_env.evaluation.fuel_chart import FUEL_CHART_FILE
from hev_thermal_env.evaluation.yardstick import REFERENCE
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.scenarios import list_scenarios
from hev_thermal_env.tasks import get_task, list_tasks

from .errors import report
from .run import strategies_help

EXAMPLES = (
    "python evaluate.py benchmark --out results                       # the README's table",
    "python evaluate.py benchmark --cycles hwfet beijing --scenarios paper hot --out results_hot",
    "python evaluate.py benchmark --task udds-hot --strategies engine_only rule ecms_thermal --out results_udds_hot",
    "python evaluate.py benchmark --strategies rule dp ppo ppo:runs/ppo --cycles udds --jobs 2 --out cmp",
    "python evaluate.py benchmark --strategies rule --family ppo5=runs/s0,runs/s1,runs/s2,runs/s3,runs/s4 --out fam",
    "python evaluate.py benchmark --family ppo_hot=runs/hot_seeds --out fam   # every train.py run in the folder",
    "python evaluate.py benchmark --executor ray --out results_ray        # one Ray task per run",
    "python evaluate.py benchmark --executor ray --address HEAD:6379 --out results   # on a Ray cluster",
)

HELP = "every strategy on every cycle and scenario: table + plots"
DESCRIPTION = ("Run every strategy on every cycle in every scenario; write results.csv, "
               "results.json, results.md, timings.json and PNG plots into --out. Every run "
               f"is measured against the thermal optimum {REFERENCE} of its cycle and scenario "
               "(frontier ratio, fixed-price ratio); dp is thermal-blind.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cycles", nargs="+", default=None, metavar="CYCLE",
                   help=f"built-in cycles ({', '.join(list_cycles())}), generated ones (FAMILY:SEED, "
                        f"validation_bus:K), sets (validation_bus, validation_bus:A..B) or CSV paths "
                        f"(default: {' '.join(DEFAULT_CYCLES)})")
    p.add_argument("--task", default=None, metavar="NAME",
                   help=f"a benchmark task ({', '.join(list_tasks())}; a name alone is its newest version): its "
                        "cycles and scenario, instead of --cycles and --scenarios; its record goes to task.json")
    p.add_argument("--strategies", nargs="+", default=list(DEFAULT_STRATEGIES), metavar="STRATEGY",
                   help=f"{strategies_help()}; {REFERENCE}, the reference of the ratios, is added if missing")
    p.add_argument("--family", action="append", default=[], metavar="NAME=PATH,PATH,...",
                   help=f"a seed family: at least {MIN_SEEDS} trained runs (what ppo:PATH loads) of one training "
                        "setup, or one directory holding such runs; reported as the interquartile mean over the "
                        "seeds with a 95 %% bootstrap interval (repeat for several families)")
    p.add_argument("--scenarios", nargs="+", default=None, metavar="SCENARIO",
                   help=f"scenarios ({', '.join(list_scenarios())}) (default: {' '.join(DEFAULT_SCENARIOS)})")
    p.add_argument("--out", default="results", metavar="DIR", help="output directory")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help=f"parallel processes, or CPUs of the local Ray runtime (default: the number of cores, "
                        f"{os.cpu_count() or 1} here)")
    p.add_argument("--executor", choices=EXECUTORS, default="local",
                   help="local: this machine's processes; ray: one Ray task per run (needs the ray extra)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="with --executor ray: join the Ray cluster at HOST:PORT (started with 'ray start --head') "
                        "instead of starting a local runtime")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")


def main(args: argparse.Namespace) -> int:
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    families, taken = [], set(list_strategies()) | set(args.strategies)
    for text in args.family:
        family = parse_family(text, taken)
        families.append(family)
        taken.add(family.name)
    cycles, scenarios, task = _cycles_and_scenarios(args)
    t0 = time.perf_counter()
    try:
        rows = run_benchmark(Path(args.out), expand_cycle_names(cycles), args.strategies, scenarios,
                             jobs=args.jobs, plots=not args.no_plots, executor=args.executor, address=args.address,
                             families=families, **({} if task is None else {"physics": task.physics}))
    except ExecutorError as exc:
        return report(exc)
    if task is not None:
        atomic_write_json(Path(args.out) / "task.json", {**task.to_dict(), "digest": task.digest()})
        print(f"task {task.id}: {task.description}")
    print((Path(args.out) / "results.md").read_text())
    n_runs = sum(1 for r in rows if r.get("family") is None or r["family"] != r["strategy"])
    print(f"{n_runs} runs in {time.perf_counter() - t0:.1f} s")
    print(f"table: {Path(args.out) / 'results.md'} (also results.csv, results.json)")
    if not args.no_plots:
        print(f"plots: {Path(args.out) / FUEL_CHART_FILE}, {Path(args.out)}/traces_<cycle>_<scenario>.png")
    return 0


def _cycles_and_scenarios(args: argparse.Namespace) -> tuple[list[str], list[str], Any]:
    """The cycles and scenarios to run: ``--task``'s, or ``--cycles`` and ``--scenarios`` (with their defaults); and the
    task (or None)."""
    if args.task is None:
        return (args.cycles or list(DEFAULT_CYCLES), args.scenarios or list(DEFAULT_SCENARIOS), None)
    if args.cycles is not None or args.scenarios is not None:
        raise ValueError(f"--task {args.task} sets the cycles and the scenario; drop --cycles and --scenarios")
    task = get_task(args.task)
    if task.seeds != (0,) or task.start_s != 0:
        raise ValueError(f"--task {task.id}: the benchmark runs each cycle once from second 0 with seed 0; this task's "
                         f"episodes (seeds {list(task.seeds)}, start {task.start_s} s) need its own runner")
    return list(task.cycles), [task.scenario], task
