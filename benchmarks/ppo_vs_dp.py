#!/usr/bin/env python
"""Learned policies against the thermal optimum's frontier: a PPO seed family, shipped policies, baselines.

For every seed, ``train.py`` trains a PPO policy with the default hyperparameters
(``agents/hyperparams/ppo.yaml``: imitation of ``ecms_thermal``, then PPO on generated cycle families,
never ``hwfet``, ``beijing`` nor a validation cycle; ``best_model.zip`` chosen on fuel against ECMS on
``validation_bus:20..29``, never on a cycle of this benchmark) into
``RUNS/seed_S`` (skipped with ``--reuse`` when the run has finished). The seeds' models (``--model``:
``best_model.zip`` by default, or the final ``model.zip``), the shipped policy ``ppo``, every
``--policy NAME=PATH`` and the baselines (``rule``, ``ecms``, ``ecms_thermal``) then drive every cell
(cycle × scenario):

* ``paper``: ``hwfet``, ``beijing``, ``udds``, ``us06``, ``wltc_3b`` and ``--validation N``
  generated validation cycles ``validation_bus:0..N-1`` (long, congested, launch, hilly, mixed;
  1,200-4,500 s);
* ``hot`` and ``summer``: ``hwfet`` and ``beijing``.

The thermal optimum (``dp_thermal``) is solved once per cell; every run's cost is divided by the
optimum's frontier at the run's own final SOC (:mod:`hev_thermal_env.evaluation.yardstick`). The
seed family is summarised by the interquartile mean over seeds and its 95 % bootstrap interval
(:mod:`hev_thermal_env.stats`); the tables and verdicts are built by ``ppo_vs_dp_report.py``.
Cells run in parallel (``--jobs`` worker processes, one cell each at a time).

Writes ``OUT/ppo_vs_dp.json`` (every number), ``OUT/ppo_vs_dp.md`` (tables, targets, met / not met)
and ``OUT/ppo_vs_dp.png`` (ratio and ΔSOC per cell)::

    python benchmarks/ppo_vs_dp.py --seeds 0 1 2 3 4 --runs runs/ppo_vs_dp --jobs 2 --out benchmarks/results
    python benchmarks/ppo_vs_dp.py --seeds 0 1 --train-args "--timesteps 20000" --quick --out /tmp/ppo_smoke
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import shutil
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

PAPER_CYCLES = ("hwfet", "beijing", "udds", "us06", "wltc_3b")
THERMAL_SCENARIOS = ("hot", "summer")
THERMAL_CYCLES = ("hwfet", "beijing")
BASELINES = ("rule", "ecms", "ecms_thermal")
SHIPPED = "ppo"
REFERENCE = "dp_thermal"
ROW_KEYS = ("cost_g", "soc_final", "delta_soc", "cutoff_s", "derated_s", "fuel_corrected_l_per_100km",
            "fuel_l_per_100km", "trace_miss_max_mps", "max_motor_temp_c", "heat_index_max", "wall_s")
MODEL_FILES = {"best": "best_model.zip", "final": "model.zip"}


def train_seed(seed: int, runs: Path, reuse: bool, extra: list[str]) -> dict[str, Any]:
    """Train seed ``seed`` into ``runs/seed_S`` (or reuse a finished run); its config and the wall time measured."""
    from hev_thermal_env.training.config import load_run_config

    out = runs / f"seed_{seed}"
    if reuse and (out / "model.zip").is_file():
        cfg = load_run_config(out)
        if (cfg.get("result") or {}).get("finished"):
            print(f"seed {seed}: reusing {out}", flush=True)
            return {"config": cfg, "process_wall_s": None}
    if out.exists():
        shutil.rmtree(out)
    shown = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out  # recorded in command.txt
    cmd = [sys.executable, "train.py", "--algo", "ppo", "--seed", str(seed), "--out", str(shown), "--no-progress",
           *extra]
    print("$ " + " ".join(shlex.quote(c) for c in cmd), flush=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, check=True)
    wall = time.perf_counter() - t0
    print(f"seed {seed}: trained in {wall:.0f} s (incl. the final validation)", flush=True)
    return {"config": load_run_config(out), "process_wall_s": round(wall, 1)}


def training_row(seed: int, run_dir: Path, trained: dict[str, Any]) -> dict[str, Any]:
    """What the report shows of one seed's training: the ``result`` section of its config.yaml."""
    from hev_thermal_env.cycles.names import expand_cycle_names

    res = trained["config"].get("result") or {}
    validation = ((res.get("validation") or {}).get("models") or {})
    command = run_dir / "command.txt"
    selection = expand_cycle_names(list((trained["config"].get("eval") or {}).get("cycles") or []))
    return {"seed": seed, "run": str(run_dir), "timesteps": res.get("timesteps_done"), "wall_s": res.get("wall_s"),
            "selection_cycles": selection,
            "steps_per_s": res.get("steps_per_s"), "env_share": res.get("env_share"),
            "process_wall_s": trained["process_wall_s"], "best_eval": res.get("best_eval"),
            "validation_vs_ecms": {k: v.get("mean_fuel_ratio") for k, v in validation.items()},
            "command": " ".join(command.read_text().split()) if command.is_file() else None}


def run_row(label: str, cycle: Any, scenario: str, frontier: Any) -> dict[str, Any]:
    """One strategy on one cell: the summary's numbers and the frontier ratio."""
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.runner import run_strategy
    from hev_thermal_env.evaluation.yardstick import frontier_ratio

    s = run_strategy(get_strategy(label), cycle, scenario).summary
    ratio, note = frontier_ratio(s["cost_g"], s["soc_final"], frontier)
    return {"strategy": label, **{k: s[k] for k in ROW_KEYS}, "frontier_ratio": ratio, "frontier_note": note}


def solve_cell(task: tuple[str, str, dict[str, str], int]) -> dict[str, Any]:
    """Solve the optimum of one cycle × scenario once, then run every policy and baseline there."""
    cycle_name, scenario, labels, threads = task
    warnings.simplefilter("ignore")
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.cycles import load_cycle
    from hev_thermal_env.evaluation.runner import run_strategy
    from hev_thermal_env.evaluation.yardstick import Frontier, frontier_sample

    cycle = load_cycle(cycle_name)
    t0 = time.perf_counter()
    opt = run_strategy(get_strategy(REFERENCE, on_infeasible="closest", threads=threads), cycle, scenario).summary
    wall = time.perf_counter() - t0
    d = opt["strategy_settings"]
    frontier = Frontier.from_settings(d)
    t1 = time.perf_counter()
    runs = {name: run_row(label, cycle, scenario, frontier) for name, label in labels.items()}
    optimum = {k: opt[k] for k in ROW_KEYS}
    optimum.update(solve_s=d.get("solve_s"), optimum_wall_s=round(wall, 2), planned_cost_g=d.get("planned_cost_g"),
                   max_states=d.get("max_states"), grid=frontier.grid if frontier else None,
                   frontier=frontier_sample(frontier.soc_final, frontier.cost_g) if frontier else None)
    return {"cycle": cycle_name, "scenario": scenario, "duration_s": len(cycle.speed_mps) - 1,
            "distance_km": opt.get("distance_km"), "family": cycle_family(cycle_name), "optimum": optimum,
            "runs": runs, "runs_wall_s": round(time.perf_counter() - t1, 2)}


def cycle_family(name: str) -> str:
    """``built-in`` or the generated family of a validation cycle."""
    from hev_thermal_env.cycles.validation import VALIDATION_SET, validation_family

    if name.startswith(VALIDATION_SET + ":"):
        return validation_family(int(name.split(":", 1)[1]))
    return "built-in"


def _init_worker() -> None:
    import torch

    torch.set_num_threads(1)
    warnings.simplefilter("ignore")


def run_cells(tasks: list[tuple], jobs: int) -> list[dict[str, Any]]:
    """Every cell, longest cycle first, ``jobs`` at a time, with a progress bar; in task order."""
    from multiprocessing import Pool

    from tqdm import tqdm

    from hev_thermal_env.cycles import load_cycle

    warnings.simplefilter("ignore")
    order = sorted(range(len(tasks)), key=lambda i: -len(load_cycle(tasks[i][0]).speed_mps))
    done: dict[tuple[str, str], dict[str, Any]] = {}
    bar = tqdm(total=len(tasks), desc="cells", unit="cell", smoothing=0)

    def record(cell: dict[str, Any]) -> None:
        done[(cell["cycle"], cell["scenario"])] = cell
        bar.update()
        bar.write(f"{cell['cycle']} / {cell['scenario']}: optimum {cell['optimum']['optimum_wall_s']:.0f} s, "
                  f"runs {cell['runs_wall_s']:.0f} s")

    if jobs <= 1:
        _init_worker()
        for i in order:
            record(solve_cell(tasks[i]))
    else:
        with Pool(jobs, initializer=_init_worker) as pool:
            for cell in pool.imap_unordered(solve_cell, [tasks[i] for i in order], chunksize=1):
                record(cell)
    bar.close()
    return [done[(t[0], t[1])] for t in tasks]


def parse_policies(items: list[str]) -> dict[str, str]:
    """``--policy NAME=PATH`` values as {name: strategy label}, the shipped ``ppo`` first."""
    policies = {SHIPPED: SHIPPED}
    for item in items:
        name, sep, path = item.partition("=")
        name, path = name.strip(), path.strip()
        if not sep or not name or not path:
            raise SystemExit(f"--policy {item!r}: expected NAME=PATH (a train.py run directory or a model zip)")
        if name in policies or name in BASELINES or name.startswith("seed_") or name == REFERENCE:
            raise SystemExit(f"--policy {name!r}: the name is taken (ppo, seed_S, baselines); choose another")
        if not Path(path).expanduser().exists():
            raise SystemExit(f"--policy {name}: {path} not found")
        policies[name] = f"ppo:{Path(path).expanduser().resolve()}"
    return policies


def check_policies(labels: dict[str, str]) -> dict[str, str | None]:
    """Load every policy once before the cells (a bad path fails here); whether each was trained on other physics."""
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.agents.policy_files import warn_if_other_physics

    found = {}
    for name, label in labels.items():
        policy = get_strategy(label).policy
        found[name] = warn_if_other_physics(policy.path, policy.config)
    return found


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2, 3, 4], help="training seeds of the family")
    p.add_argument("--runs", default="runs/ppo_vs_dp", help="directory of the training runs (seed_S)")
    p.add_argument("--reuse", action="store_true", help="reuse finished runs instead of training again")
    p.add_argument("--train-args", default="", help="extra train.py arguments, quoted (e.g. \"--timesteps 100000\")")
    p.add_argument("--model", choices=sorted(MODEL_FILES), default="best",
                   help="which model of each seed: best (best_model.zip, the training's selection) or final")
    p.add_argument("--policy", action="append", default=[], metavar="NAME=PATH",
                   help="an already-trained policy to add (repeatable); the shipped 'ppo' is always in")
    p.add_argument("--validation", type=int, default=20, help="validation cycles validation_bus:0..N-1 (paper)")
    p.add_argument("--quick", action="store_true",
                   help="smoke test: hwfet + beijing (paper), hwfet (hot, summer), 2 validation cycles")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (one cell each)")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    args = p.parse_args(argv)
    from hev_thermal_env.cycles.validation import VALIDATION_SIZE

    if not 0 <= args.validation <= VALIDATION_SIZE:
        p.error(f"--validation {args.validation}: expected 0-{VALIDATION_SIZE}")
    if args.jobs < 1:
        p.error(f"--jobs {args.jobs}: expected at least 1")
    if len(set(args.seeds)) != len(args.seeds):
        p.error(f"--seeds {args.seeds}: a seed is repeated")
    return args


def cells_of(args: argparse.Namespace) -> list[tuple[str, str]]:
    """The (cycle, scenario) cells of the run."""
    paper = PAPER_CYCLES[:2] if args.quick else PAPER_CYCLES
    thermal = THERMAL_CYCLES[:1] if args.quick else THERMAL_CYCLES
    n_val = min(2, args.validation) if args.quick else args.validation
    return ([(c, "paper") for c in paper] + [(c, s) for s in THERMAL_SCENARIOS for c in thermal]
            + [(f"validation_bus:{k}", "paper") for k in range(n_val)])


def git_commit() -> str | None:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    import ppo_vs_dp_report as report
    import torch

    from hev_thermal_env.io import atomic_write_json, atomic_write_text

    torch.set_num_threads(1)
    policies = parse_policies(args.policy)
    runs = Path(args.runs) if Path(args.runs).is_absolute() else ROOT / args.runs
    extra = shlex.split(args.train_args)
    t_train = time.perf_counter()
    trained = {s: train_seed(s, runs, args.reuse, extra) for s in args.seeds}
    train_wall = time.perf_counter() - t_train
    seeds = {f"seed_{s}": f"ppo:{runs / f'seed_{s}' / MODEL_FILES[args.model]}" for s in args.seeds}
    labels = {**seeds, **policies, **{b: b for b in BASELINES}}
    policy_warnings = check_policies({**seeds, **policies})
    threads = max(1, (os.cpu_count() or 1) // args.jobs)
    cells = [(c, s, labels, threads) for c, s in cells_of(args)]
    t0 = time.perf_counter()
    results = run_cells(cells, args.jobs)
    data = {
        "command": " ".join(shlex.quote(a) for a in ["python", "benchmarks/ppo_vs_dp.py", *(argv or sys.argv[1:])]),
        "commit": git_commit(), "seeds": list(seeds), "model": MODEL_FILES[args.model],
        "policies": list(policies), "baselines": list(BASELINES), "labels": labels, "reference": REFERENCE,
        "policy_warnings": policy_warnings, "targets": report.TARGETS, "cells": results,
        "training": [training_row(s, runs / f"seed_{s}", trained[s]) for s in args.seeds],
        "training_wall_s": round(train_wall, 1), "eval_wall_s": round(time.perf_counter() - t0, 1),
        "jobs": args.jobs, "optimum_threads": threads,
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                   f"{args.jobs} worker(s), torch threads 1",
    }
    data["summary"] = report.summarize(data)
    data = json.loads(json.dumps(data).replace(str(ROOT) + "/", ""))  # paths relative to the repository
    out = Path(args.out)
    atomic_write_json(out / "ppo_vs_dp.json", data)
    md = report.markdown(data)
    atomic_write_text(out / "ppo_vs_dp.md", md)
    report.plot(data, out / "ppo_vs_dp.png")
    print(md)
    print(json.dumps({"written": [str(out / f) for f in ("ppo_vs_dp.json", "ppo_vs_dp.md", "ppo_vs_dp.png")]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
