#!/usr/bin/env python
"""The learned baselines side by side: every method of ``train.py``, seeds 0-4, evaluated on every named task.

Each method (:data:`METHODS`: PPO, SAC, TQC, RecurrentPPO, PPO-Lagrangian) trains with its hyperparameter file
(``agents/hyperparams/<algo>.yaml``: its stated budget of env-steps) on the generalisation task's training
distribution (``train.py --task bus-generalisation``: a fresh route of every generated bus family per episode,
``random_service`` conditions; never a test, validation or standard cycle), one ``train.py`` process per seed, the
seeds fixed in advance (:data:`SEEDS`, no picking among extra seeds), into ``RUNS/METHOD/seed_S`` (a finished run
is reused). The policy evaluated is each run's ``best_model.zip`` (selected on ``validation_bus:20..29``, never on a
task's cycles). Every seed family then drives every task (``--tasks``, default all) through the benchmark
(:func:`hev_thermal_env.evaluation.benchmark.run_benchmark`: frontier ratio per run against the thermal optimum,
IQM over seeds with its 95 % bootstrap interval), beside ``engine_only``; the episode safety cost (the sum of
``info["cost"]``) of every policy on every task episode is the run summary's ``safety_cost_s``.

Writes ``OUT/learned_baselines.json``: per method its budget and per seed the process wall-clock, the training's
steps/s and the saved policy's path; per task and method the frontier ratio IQM [95 % CI], each seed's ratios,
ΔSOC, cut-off and derated seconds and episode safety cost. Normalised scores come from the leaderboard machinery
where the package has it (:func:`normalised_scores`, the hook; until then the JSON says so and holds the ratios)::

    python benchmarks/learned_baselines.py --methods ppo --runs runs/learned --out benchmarks/results   # one method
    python benchmarks/learned_baselines.py --runs runs/learned --out benchmarks/results    # all methods, the table
    python benchmarks/learned_baselines.py --smoke --out /tmp/learned_smoke   # tiny budgets, 2 seeds, hwfet only
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
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: The methods, by ``train.py --algo`` name.
METHODS = ("ppo", "sac", "tqc", "recurrent_ppo", "ppo_lagrangian")
#: Each method's name in the benchmark's tables (its seed family; a family may not take a strategy's name, ``ppo``).
FAMILY_NAMES = {"ppo": "PPO", "sac": "SAC", "tqc": "TQC", "recurrent_ppo": "RecurrentPPO",
                "ppo_lagrangian": "PPO-Lagrangian"}
#: The seeds of every method, fixed before any run.
SEEDS = (0, 1, 2, 3, 4)
#: The task whose training distribution every method trains on.
TRAINING_TASK = "bus-generalisation"
#: Per method, ``train.py --hp`` settings of every run: the constrained method's budget is the training task's stored
#: one (its episode safety budget per hour driven, :func:`hev_thermal_env.training.lagrangian.task_budget_s_per_h`).
METHOD_HP = {"ppo_lagrangian": ["constraint.budget_s_per_h=task"]}
#: ``--smoke``: seeds (a seed family needs two), tasks, and per method the ``train.py`` arguments of a tiny run.
SMOKE_SEEDS = (0, 1)
SMOKE_TASKS = ("hwfet",)
_SMOKE_COMMON = ["--timesteps", "512", "--n-envs", "2", "--eval-cycles", "--checkpoint-freq", "512"]
_SMOKE_PPO = ["n_steps=64", "batch_size=64", "n_epochs=1", "policy_kwargs.net_arch=[16,16]", "init.episodes=1",
              "init.epochs=1"]
_SMOKE_OFF_POLICY = ["learning_starts=128", "buffer_size=1000", "batch_size=32", "policy_kwargs.net_arch=[16,16]"]
SMOKE_ARGS = {
    "ppo": [*_SMOKE_COMMON, "--hp", *_SMOKE_PPO],
    "ppo_lagrangian": [*_SMOKE_COMMON, "--hp", *_SMOKE_PPO, *METHOD_HP["ppo_lagrangian"]],
    "sac": [*_SMOKE_COMMON, "--hp", *_SMOKE_OFF_POLICY],
    "tqc": [*_SMOKE_COMMON, "--hp", *_SMOKE_OFF_POLICY, "policy_kwargs.n_quantiles=5"],
    "recurrent_ppo": [*_SMOKE_COMMON, "--hp", "n_steps=64", "batch_size=64", "n_epochs=1",
                      "policy_kwargs.net_arch=[16,16]", "policy_kwargs.lstm_hidden_size=8"],
}
ROW_KEYS = ("frontier_ratio", "fixed_price_ratio", "delta_soc", "charge_sustaining", "cutoff_s", "derated_s",
            "fuel_corrected_l_per_100km", "cost_g")
POLICY_FILE = "best_model.zip"


def train_seed(method: str, seed: int, runs: Path, extra: list[str]) -> dict[str, Any]:
    """Train ``method`` with ``seed`` into ``runs/METHOD/seed_S`` (a finished run there is reused); what the JSON
    records of it."""
    from hev_thermal_env.training.config import load_run_config

    out = runs / method / f"seed_{seed}"
    process_wall = None
    finished = (out / "config.yaml").is_file() and (load_run_config(out).get("result") or {}).get("finished")
    if finished:
        print(f"{method} seed {seed}: reusing {out}", flush=True)
    else:
        if out.exists():
            shutil.rmtree(out)
        shown = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out
        cmd = [sys.executable, "train.py", "--algo", method, "--task", TRAINING_TASK, "--seed", str(seed), "--out",
               str(shown), "--no-progress", *extra]
        print("$ " + " ".join(shlex.quote(c) for c in cmd), flush=True)
        t0 = time.perf_counter()
        subprocess.run(cmd, cwd=ROOT, check=True)
        process_wall = round(time.perf_counter() - t0, 1)
    res = load_run_config(out).get("result") or {}
    return {"seed": seed, "run_dir": str(out), "policy": str(out / POLICY_FILE), "process_wall_s": process_wall,
            "train_wall_s": res.get("wall_s"), "timesteps": res.get("timesteps_done"),
            "steps_per_s": res.get("steps_per_s"), "env_share": res.get("env_share"),
            "imitation_wall_s": (res.get("imitation") or {}).get("wall_s"), "lagrangian": res.get("lagrangian")}


def evaluate_task(task_id: str, families: dict[str, list[str]], out: Path, jobs: int) -> dict[str, Any]:
    """Every seed family (method -> policy paths) and ``engine_only`` on the task's episodes; the ratios and safety
    costs by method."""
    from hev_thermal_env.evaluation.benchmark import run_benchmark
    from hev_thermal_env.evaluation.families import OVERALL, Family
    from hev_thermal_env.tasks import get_task

    task = get_task(task_id)
    fams = [Family(FAMILY_NAMES[m], tuple(paths)) for m, paths in families.items()]
    t0 = time.perf_counter()
    rows = run_benchmark(out / task.id, cycles=list(task.cycles), strategies=["engine_only"],
                         scenarios=[task.scenario], jobs=jobs, plots=False, progress=False, families=fams)
    record: dict[str, Any] = {"cycles": list(task.cycles), "scenario": task.scenario, "methods": {},
                              "engine_only": [_row(r) for r in rows if r["strategy"] == "engine_only"],
                              "wall_s": round(time.perf_counter() - t0, 1)}
    method_of = {name: m for m, name in FAMILY_NAMES.items()}
    for fam in fams:
        overall = next(r for r in rows if r.get("family") == fam.name and r["cycle"] == OVERALL)
        seeds = []
        for path, label in zip(fam.paths, fam.members):
            runs = [r for r in rows if r["strategy"] == label]
            seeds.append({"policy": path, "episodes": [_row(r) for r in runs],
                          "safety_cost_s": [round(float(r["safety_cost_s"]), 3) for r in runs]})
        record["methods"][method_of[fam.name]] = {
            "frontier_ratio_iqm": overall["frontier_ratio"],
            "frontier_ratio_ci95": [overall["frontier_ratio_ci_low"], overall["frontier_ratio_ci_high"]],
            "charge_sustaining_runs": overall["charge_sustaining_runs"], "runs": overall["runs"], "seeds": seeds}
    return record


def _row(r: dict[str, Any]) -> dict[str, Any]:
    return {"cycle": r["cycle"], **{k: r.get(k) for k in ROW_KEYS}}


def normalised_scores(evaluation: dict[str, Any]) -> dict[str, Any] | None:
    """The normalised score (0 = ``engine_only``, 100 = the thermal optimum) IQM [95 % CI] per task and method, from
    the package's leaderboard machinery; None while the package has none (the JSON then holds the frontier ratios,
    from which the score follows per episode as 100 · (r₀ − r) / (r₀ − 1), r₀ ``engine_only``'s ratio)."""
    return None


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("::")[-1])
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS, metavar="ALGO",
                   help=f"methods to train and evaluate (default: all: {', '.join(METHODS)})")
    p.add_argument("--tasks", nargs="+", default=None, metavar="TASK", help="tasks to evaluate on (default: all)")
    p.add_argument("--runs", default=str(ROOT / "runs" / "learned_baselines"), metavar="DIR",
                   help="where the runs go, RUNS/METHOD/seed_S")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results"), metavar="DIR",
                   help="where learned_baselines.json and the benchmark's files go")
    p.add_argument("--jobs", type=int, default=1, help="benchmark worker processes (default 1)")
    p.add_argument("--train-only", action="store_true", help="train (or reuse) the runs; evaluate nothing")
    p.add_argument("--smoke", action="store_true",
                   help=f"tiny budgets ({' '.join(_SMOKE_COMMON[:2])} env-steps), seeds "
                        f"{', '.join(map(str, SMOKE_SEEDS))}, tasks {', '.join(SMOKE_TASKS)}: the pipeline end to end")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    from hev_thermal_env.physics.fingerprint import physics_fingerprint
    from hev_thermal_env.tasks import get_task, list_tasks

    seeds = SMOKE_SEEDS if args.smoke else SEEDS
    task_ids = [get_task(t).id for t in (args.tasks or (SMOKE_TASKS if args.smoke else list_tasks()))]
    runs, out = Path(args.runs), Path(args.out)
    if args.smoke and args.runs == str(ROOT / "runs" / "learned_baselines"):
        runs = out / "runs"
    out.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {
        "training_task": get_task(TRAINING_TASK).id, "seeds": list(seeds), "smoke": args.smoke,
        "policy_file": POLICY_FILE, "physics_fingerprint": physics_fingerprint(),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "load_at_start": os.getloadavg()},
        "methods": {}, "evaluation": {}}
    for method in args.methods:
        extra = SMOKE_ARGS[method] if args.smoke else (["--hp", *METHOD_HP[method]] if method in METHOD_HP else [])
        record["methods"][method] = {"train_args": extra, "seeds": [train_seed(method, s, runs, extra) for s in seeds]}
    if not args.train_only:
        families = {m: [s["policy"] for s in r["seeds"]] for m, r in record["methods"].items()}
        for task_id in task_ids:
            print(f"evaluating on {task_id}", flush=True)
            record["evaluation"][task_id] = evaluate_task(task_id, families, out / "learned_baselines_eval", args.jobs)
    record["normalised_scores"] = normalised_scores(record["evaluation"])
    if record["normalised_scores"] is None:
        record["normalised_scores_note"] = ("no leaderboard machinery in the package yet: frontier ratios only; "
                                            "normalised_scores() is the hook")
    record["machine"]["load_at_end"] = os.getloadavg()
    path = out / "learned_baselines.json"
    path.write_text(json.dumps(record, indent=1, default=str) + "\n")
    print(f"wrote {path}", flush=True)
    for method, r in record["methods"].items():
        rates = [s["steps_per_s"] for s in r["seeds"]]
        print(f"{method}: steps/s per seed {rates}", flush=True)
    for task_id, ev in record["evaluation"].items():
        for method, m in ev["methods"].items():
            lo, hi = m["frontier_ratio_ci95"]
            print(f"{task_id} {method}: frontier ratio IQM {m['frontier_ratio_iqm']} [{lo}, {hi}]", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
