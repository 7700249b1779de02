#!/usr/bin/env python
"""The learned baselines side by side: every method of ``train.py``, seeds 0-4, evaluated on every named task.

Each method (:data:`METHODS`: PPO, PPO on the RL track, SAC, TQC, RecurrentPPO, PPO-Lagrangian) trains with its
hyperparameter file (``agents/hyperparams/<method>.yaml``: its stated budget of env-steps) on the generalisation task's
training distribution (``train.py --task bus-generalisation``: a fresh route of every generated bus family per episode,
``random_service`` conditions; never a test, validation or standard cycle), one ``train.py`` process per seed, the seeds
fixed in advance (:data:`SEEDS`, no picking among extra seeds), into ``RUNS/METHOD/seed_S`` (a finished run is reused).
The policy evaluated is each run's ``best_model.zip`` (selected on ``validation_bus:20..29``, never on a task's cycles);
``--also NAME=DIR`` scores a family of finished runs ``DIR/seed_S`` beside them (``--also-final``: their final
``model.zip``). Behaviour cloning (``bc``, :data:`BC`) fits seeds 0-4 to the thermal optimum's offline dataset on one
route of every training family (``evaluate.py dataset --source optimum``, then ``evaluate.py bc``; the dataset is reused
when there). Every seed family then drives every episode of every task (``--tasks``, default all) and is scored against
the task's stored reference, as the leaderboard scores any result (no optimum is solved here): the normalised score (0 =
``engine_only``, 100 = the thermal optimum) and the frontier ratio, IQM over episodes and seeds with the 95 % stratified
bootstrap interval, the episode safety cost (Σ ``info["cost"]``) against the task's budget and the optimum's (+5 %), and
the runs beyond |ΔSOC| 0.02.

Every family's track (``RL`` or ``guided``) is read from its runs' configs
(:func:`hev_thermal_env.evaluation.submission.track_of`: guided when the run's start imitates a strategy); BC is guided.
Writes ``OUT/learned_baselines.json``: per method its budget and per seed the process wall-clock, the training's steps/s
and the saved policy's path (``bc``: the dataset's build time and each fit's); per task and method the scores, ratios
and safety costs, and every seed's episodes. ``OUT/learned_baselines.md`` is the table; ``OUT/learned_baselines/<task
id>/<method>.json`` are result files (:mod:`hev_thermal_env.evaluation.submission`), which ``evaluate.py leaderboard
--results`` places on the leaderboard with the training wall-clock per seed; ``OUT/learned_baselines_curves.png`` the
learning curves::

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
METHODS = ("ppo", "ppo_rl", "sac", "tqc", "recurrent_ppo", "ppo_lagrangian")
#: Each method's name in the benchmark's tables (its seed family; a family may not take a strategy's name, ``ppo``).
#: ``ppo_rl`` is PPO on the RL track (its own file, no teacher), ``PPO`` beside the guided recipe's: the tables tell
#: them apart by their tracks.
FAMILY_NAMES = {"ppo": "PPO", "ppo_rl": "PPO", "sac": "SAC", "tqc": "TQC", "recurrent_ppo": "RecurrentPPO",
                "ppo_lagrangian": "PPO-Lagrangian"}
#: A method's result file name where it is not its family name.
FILE_NAMES = {"ppo_rl": "PPO-RL"}
#: A method that is another method's algorithm with its own hyperparameter file: its ``train.py --algo`` and file.
FROM_FILE = {"ppo_rl": ("ppo", "agents/hyperparams/ppo_rl.yaml")}
#: Behaviour cloning from the optimum's offline dataset (``evaluate.py dataset``, then ``evaluate.py bc --seeds``): one
#: route of every training family of the generalisation task, in ``paper``, driven by the thermal optimum.
BC = "bc"
BC_NAME = "BC (optimum)"
BC_DATASET = "hev-thermal/train-paper-7/optimum-v0"
BC_DATASET_ARGS = ["--source", "optimum", "--routes", "7", "--families", "random_bus", "bus_long", "bus_congested",
                   "bus_launch", "bus_hilly", "bus_mixed", "bus_express"]
#: ``--smoke``: ECMS on one short-lived route instead of the optimum, two passes of the fit.
SMOKE_BC_DATASET = "hev-thermal/train-paper-1/ecms-v0"
SMOKE_BC_DATASET_ARGS = ["--source", "ecms", "--routes", "1", "--families", "bus_launch"]
SMOKE_BC_ARGS = ["--epochs", "2"]
#: The seeds of every method, fixed before any run.
SEEDS = (0, 1, 2, 3, 4)
#: Every method's name in the tables.
NAMES = {**FAMILY_NAMES, BC: BC_NAME}
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
    "ppo_rl": [*_SMOKE_COMMON, "--hp", *_SMOKE_PPO[:4]],
    "sac": [*_SMOKE_COMMON, "--hp", *_SMOKE_OFF_POLICY],
    "tqc": [*_SMOKE_COMMON, "--hp", *_SMOKE_OFF_POLICY, "policy_kwargs.n_quantiles=5"],
    "recurrent_ppo": [*_SMOKE_COMMON, "--hp", "n_steps=64", "batch_size=64", "n_epochs=1",
                      "policy_kwargs.net_arch=[16,16]", "policy_kwargs.lstm_hidden_size=8"],
}
ROW_KEYS = ("cycle", "env_seed", "cost_g", "soc_final", "safety_cost_s", "fuel_g", "fuel_corrected_l_per_100km",
            "charge_sustaining")
POLICY_FILE = "best_model.zip"
#: Where the result files of ``--also`` families (variants of a method's recipe) go, under ``--out``.
ABLATION_DIR = "ablation"


def train_seed(method: str, seed: int, runs: Path, extra: list[str]) -> dict[str, Any]:
    """Train ``method`` with ``seed`` into ``runs/METHOD/seed_S`` (a finished run there is reused); what the JSON
    records of it."""
    out = runs / method / f"seed_{seed}"
    process_wall = None
    if _finished(out):
        print(f"{method} seed {seed}: reusing {out}", flush=True)
    else:
        if out.exists():
            shutil.rmtree(out)
        shown = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out
        algo, hyperparams = FROM_FILE.get(method, (method, None))
        cmd = [sys.executable, "train.py", "--algo", algo, "--task", TRAINING_TASK, "--seed", str(seed), "--out",
               str(shown), "--no-progress", *(["--hyperparams", hyperparams] if hyperparams else []), *extra]
        process_wall = run_command(cmd)
    return {**seed_record(out, seed), "process_wall_s": process_wall}


def run_command(cmd: list[str], env: dict[str, str] | None = None) -> float:
    """Run ``cmd`` in the checkout, shown first; its wall-clock in seconds."""
    print("$ " + " ".join(shlex.quote(c) for c in cmd), flush=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, check=True, env=env)
    return round(time.perf_counter() - t0, 1)


def _finished(out: Path) -> bool:
    from hev_thermal_env.training.config import load_run_config

    return (out / "config.yaml").is_file() and bool((load_run_config(out).get("result") or {}).get("finished"))


def seed_record(out: Path, seed: int, policy_file: str = POLICY_FILE) -> dict[str, Any]:
    """What the JSON records of the finished run in ``out`` (its policy: ``policy_file``)."""
    from hev_thermal_env.evaluation.submission import track_of
    from hev_thermal_env.training.config import load_run_config

    config = load_run_config(out)
    res = config.get("result") or {}
    return {"seed": seed, "run_dir": str(out), "policy": str(out / policy_file), "track": track_of(config),
            "train_wall_s": res.get("wall_s"), "timesteps": res.get("timesteps_done"),
            "steps_per_s": res.get("steps_per_s"), "env_share": res.get("env_share"),
            "imitation_wall_s": (res.get("imitation") or {}).get("wall_s"), "lagrangian": res.get("lagrangian")}


def evaluate_task(task_id: str, methods: dict[str, dict[str, Any]], results_dir: Path,
                  bc: dict[str, Any] | None = None, ablation_dir: Path | None = None,
                  variants: tuple[str, ...] = ()) -> dict[str, Any]:
    """Every seed family (method -> its training record) on the task's episodes, scored against the task's stored
    reference (no optimum is solved): writes ``RESULTS_DIR/<task id>/<family>.json`` (the leaderboard's result
    format) and returns per method the normalised score and frontier ratio IQM [95 % CI], the safety cost against
    the budget and every seed's episodes. ``bc``: the behaviour-cloning family's record (its result files, written
    by ``evaluate.py bc``), scored alike. ``variants`` (``--also`` families, variants of a method's recipe) write their
    result files into ``ABLATION_DIR/<task id>/`` instead: the leaderboard holds methods, the training page's
    ablation table their variants."""
    from hev_thermal_env.evaluation.references import load_reference
    from hev_thermal_env.evaluation.submission import load_result, result_of_seeds
    from hev_thermal_env.io import atomic_write_json
    from hev_thermal_env.tasks import get_task

    task = get_task(task_id)
    reference = load_reference(task)
    record: dict[str, Any] = {"cycles": list(task.cycles), "scenario": task.scenario,
                              "safety_budget_s": reference["safety_budget_s"], "methods": {}}
    for method, trained in methods.items():
        t0 = time.perf_counter()
        seeds = trained["seeds"]
        training = {"wall_clock_s_per_seed": [s["train_wall_s"] or 0.0 for s in seeds],
                    "timesteps": seeds[0]["timesteps"], "steps_per_s": _mean([s["steps_per_s"] for s in seeds])}
        path = ((ablation_dir if method in variants else results_dir) / task.id
                / f"{FILE_NAMES.get(method, FAMILY_NAMES[method])}.json")
        policies = [s["policy"] for s in seeds]
        digests = [_digest(p) for p in policies]
        track = family_track(method, seeds)
        result = _current(path)
        if result is None or result.get("policies") != policies or result.get("policy_digests") != digests:
            result = {**result_of_seeds(task, {s["seed"]: f"ppo:{s['policy']}" for s in seeds}, FAMILY_NAMES[method],
                                        training=training, track=track), "policies": policies,
                      "policy_digests": digests}
            atomic_write_json(path, result)
        elif result.get("track") != track:
            atomic_write_json(path, {**result, "track": track})
        record["methods"][method] = {**score_family(result, reference), "wall_s": round(time.perf_counter() - t0, 1)}
    if bc is not None:
        result = load_result(Path(bc["results_dir"]) / task.id / "bc.json")
        atomic_write_json(results_dir / task.id / "BC.json", result)
        record["methods"][BC] = score_family(result, reference)
    return record


def family_track(method: str, seeds: list[dict[str, Any]]) -> str:
    """A seed family's track (``RL`` or ``guided``), read from its runs' configs (:func:`seed_record`); every seed's
    must agree."""
    tracks = {s["track"] for s in seeds}
    if len(tracks) != 1:
        raise SystemExit(f"{method}: its seeds were trained on different tracks ({', '.join(sorted(tracks))})")
    return tracks.pop()


def _digest(policy: str) -> str | None:
    """A digest of a saved policy's model zip (a retrained policy at the same path is evaluated again)."""
    from hev_thermal_env.io import files_digest

    path = Path(policy) if Path(policy).is_absolute() else ROOT / policy
    return files_digest(path) if path.is_file() else None


def _current(path: Path) -> dict[str, Any] | None:
    """The result file at ``path`` if it is readable and current (a finished evaluation to reuse), else None."""
    from hev_thermal_env.evaluation.submission import load_result

    try:
        return load_result(path)
    except (ValueError, OSError):
        return None


def score_family(result: dict[str, Any], reference: dict[str, Any]) -> dict[str, Any]:
    """A family's result file scored against its task's reference: the leaderboard's entry (normalised score IQM
    [95 % CI], safety cost), the frontier ratio IQM with its own interval and every run's episode."""
    from hev_thermal_env.evaluation.leaderboard import score_result
    from hev_thermal_env.stats import stratified_iqm_ci

    entry = score_result(result, reference)
    by_episode: dict[tuple[str, int], list[float]] = {}
    episodes = []
    for row, scored in zip(result["episodes"], entry["rows"]):
        if scored["frontier_ratio"] is not None:
            by_episode.setdefault((row["cycle"], row["env_seed"]), []).append(scored["frontier_ratio"])
        delta = None if row.get("soc_initial") is None else round(row["soc_final"] - row["soc_initial"], 5)
        episodes.append({**{k: row.get(k) for k in ROW_KEYS}, "seed": row["seed"], **scored, "delta_soc": delta})
    ratio_iqm, ratio_low, ratio_high = (stratified_iqm_ci(list(by_episode.values())) if by_episode
                                        else (None, None, None))
    deltas = [abs(e["delta_soc"]) for e in episodes if e["delta_soc"] is not None]
    return {"track": result.get("track"), "score_iqm": entry["score"],
            "score_ci95": [entry["score_ci_low"], entry["score_ci_high"]],
            "scored_runs": entry["n"], "runs_without_score": entry["excluded"],
            "frontier_ratio_iqm": ratio_iqm, "frontier_ratio_ci95": [ratio_low, ratio_high],
            "safety_cost_s_iqm": entry["safety_cost_s"], "safety_cost_s_max": entry["safety_cost_max_s"],
            "within_budget": entry["within_budget"], "charge_sustaining_runs": entry["charge_sustaining"],
            "runs": entry["runs"], "max_abs_delta_soc": max(deltas) if deltas else None, **{k: entry[k] for k in (
                "beyond_soc_bound", "above_optimum_safety")},
            "training_wall_s_per_seed": (result.get("training") or {}).get("wall_clock_s_per_seed"),
            "episodes": episodes}


def train_bc(seeds: tuple[int, ...], runs: Path, task_ids: list[str], smoke: bool) -> dict[str, Any]:
    """The behaviour-cloning family: the optimum's dataset on training routes (``RUNS/bc/datasets``, reused when
    there), then ``evaluate.py bc`` with every seed, its result files in ``RUNS/bc/results``; what the JSON records."""
    root, results = runs / "bc" / "datasets", runs / "bc" / "results"
    dataset, args = (SMOKE_BC_DATASET, SMOKE_BC_DATASET_ARGS) if smoke else (BC_DATASET, BC_DATASET_ARGS)
    env = {**os.environ, "MINARI_DATASETS_PATH": str(root.resolve())}
    dataset_s = None
    if not (root / dataset).is_dir():
        dataset_s = run_command([sys.executable, "evaluate.py", "dataset", *args, "--root", str(root), "--name",
                                 dataset], env)
    bc_s = None
    if not all((_current(results / t / "bc.json") or {}).get("seeds") == list(seeds) for t in task_ids):
        cmd = [sys.executable, "evaluate.py", "bc", "--dataset", dataset, "--seeds", *map(str, seeds), "--tasks",
               *task_ids, "--results-dir", str(results), "--method", BC_NAME, *(SMOKE_BC_ARGS if smoke else [])]
        bc_s = run_command(cmd, env)
    else:
        print(f"bc: reusing {results}", flush=True)
    return {"dataset": dataset, "dataset_args": args, "dataset_wall_s": dataset_s, "seeds": list(seeds),
            "bc_wall_s": bc_s, "results_dir": str(results)}


def _mean(values: list[float | None]) -> float | None:
    known = [float(v) for v in values if v is not None]
    return round(sum(known) / len(known), 1) if known else None


def table(record: dict[str, Any]) -> str:
    """Every method on every task: score and frontier ratio IQM, safety cost (IQM; worst; budget; runs above the
    optimum's + 5 %), the largest |ΔSOC| (runs beyond 0.02)."""
    from hev_thermal_env.evaluation.leaderboard import SAFETY_MARGIN
    from hev_thermal_env.evaluation.score import SOC_BOUND, score_text

    lines = ["| task | method | track | score IQM [95 % CI] | frontier ratio IQM [95 % CI] | "
             "safety cost s (IQM; worst) | "
             f"budget s | above the optimum's safety + {100 * (SAFETY_MARGIN - 1):.0f} % (where it derates) | "
             f"max \\|ΔSOC\\| (runs > {SOC_BOUND:g}) | runs |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for task_id, ev in record["evaluation"].items():
        for method, m in ev["methods"].items():
            lo, hi = m["frontier_ratio_ci95"]
            ratio = "-" if m["frontier_ratio_iqm"] is None else f"{m['frontier_ratio_iqm']:.4f}"
            if m["frontier_ratio_iqm"] is not None and lo is not None:  # no interval from one scored episode
                ratio += f" [{lo:.4f}, {hi:.4f}]"
            left = f" ({m['runs_without_score']} without a score)" if m["runs_without_score"] else ""
            dsoc = "-" if m["max_abs_delta_soc"] is None else f"{m['max_abs_delta_soc']:.3f} ({m['beyond_soc_bound']})"
            lines.append(f"| {task_id} | {NAMES[method]} | {m.get('track') or '-'} | "
                         f"{score_text(m['score_iqm'], *m['score_ci95'])} | "
                         f"{ratio} | {m['safety_cost_s_iqm']:.1f}; {m['safety_cost_s_max']:.1f} | "
                         f"{ev['safety_budget_s']:g} | {m['above_optimum_safety']} | {dsoc} | {m['runs']}{left} |")
    return "\n".join(lines) + "\n"


def family_curves(families: dict[str, list[tuple[int, str | Path]]], path: str | Path) -> Path | None:
    """One panel per seed family (name → its ``(seed, run directory)`` pairs): the validation fuel ÷ ECMS (mean over
    the evaluation's runs) of every seed against the env-steps, the median over seeds in bold, disqualified
    evaluations (|ΔSOC| beyond :data:`~hev_thermal_env.evaluation.score.SOC_BOUND` on a run) crossed and each seed's
    ``best_model.zip`` starred (``evaluations.csv`` of every run); written to ``path``, or None when no run has
    evaluations."""
    import numpy as np

    from hev_thermal_env.evaluation.score import SOC_BOUND
    from hev_thermal_env.evaluation.styles import pyplot, save_fig
    from hev_thermal_env.training.artifacts import read_evaluations

    curves: dict[str, list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = {}
    for name, seeds in families.items():
        for seed, run_dir in seeds:
            rows = read_evaluations(Path(run_dir) / "evaluations.csv")
            steps = sorted({r["timesteps"] for r in rows})
            if not steps:
                continue
            at = [[r for r in rows if r["timesteps"] == t] for t in steps]
            curves.setdefault(name, []).append((
                seed, np.array(steps, dtype=float), np.array([np.mean([r["fuel_ratio"] for r in g]) for g in at]),
                np.array([all(r["qualified"] for r in g) for g in at]),
                np.array([any(r["best"] for r in g) for g in at])))
    if not curves:
        return None
    fig, axes = pyplot().subplots(1, len(curves), figsize=(max(3.6 * len(curves) + 0.6, 6.4), 4.2), sharey=True,
                                  squeeze=False, layout="constrained")
    for ax, (name, runs) in zip(axes[0], curves.items()):
        for seed, x, y, ok, best in runs:
            line, = ax.plot(x, 100.0 * y, lw=0.9, alpha=0.7, label=f"seed {seed}")
            ax.plot(x[~ok], 100.0 * y[~ok], "x", color=line.get_color(), ms=5)
            last_best = np.flatnonzero(best)
            if last_best.size:
                i = last_best[-1]
                ax.plot(x[i], 100.0 * y[i], "*", color=line.get_color(), ms=10, mec="k", mew=0.5)
        n = min(len(x) for _, x, *_ in runs)
        median = np.median(np.stack([y[:n] for _, _, y, *_ in runs]), axis=0)
        ax.plot(runs[0][1][:n], 100.0 * median, color="k", lw=2.0, label="median")
        ax.axhline(100.0, color="0.5", lw=0.8, ls="--")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("env-steps")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    axes[0][0].set_ylabel("validation fuel, % of ECMS's (mean of 20 runs)")
    fig.suptitle("Learning curves on the selection runs (validation_bus:20..29 × paper, full_bus)\nx: an evaluation "
                 f"with |ΔSOC| > {SOC_BOUND:g} on a run; *: best_model.zip", fontsize=9)
    return save_fig(fig, path)


def learning_curves(methods: dict[str, dict[str, Any]], path: Path) -> Path | None:
    """Every method's seed family side by side (:func:`family_curves`), each panel
    under the method's name in the tables; None when no run has evaluations."""
    return family_curves({FILE_NAMES.get(m, FAMILY_NAMES.get(m, m)): [(s["seed"], s["run_dir"]) for s in t["seeds"]]
                          for m, t in methods.items()}, path)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("::")[-1])
    p.add_argument("--methods", nargs="+", default=[*METHODS, BC], choices=[*METHODS, BC], metavar="ALGO",
                   help=f"methods to train and evaluate (default: all: {', '.join([*METHODS, BC])}; {BC}: behaviour "
                        "cloning from the optimum's dataset on training routes)")
    p.add_argument("--tasks", nargs="+", default=None, metavar="TASK", help="tasks to evaluate on (default: all)")
    p.add_argument("--runs", default=str(ROOT / "runs" / "learned_baselines"), metavar="DIR",
                   help="where the runs go, RUNS/METHOD/seed_S")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results"), metavar="DIR",
                   help="where learned_baselines.json and the benchmark's files go")
    p.add_argument("--also", nargs="+", default=[], metavar="NAME=DIR",
                   help="also score a family of finished runs DIR/seed_S (the same seeds; never trained here) under "
                        f"NAME, a variant of a method's recipe: its result files go to OUT/{ABLATION_DIR}/, off the "
                        "leaderboard")
    p.add_argument("--also-final", action="store_true",
                   help=f"score the --also families' final model.zip instead of their {POLICY_FILE}")
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
    also: dict[str, Any] = {}
    for item in args.also:
        name, sep, folder = item.partition("=")
        if not sep or not name or not folder or name in NAMES or name in NAMES.values():
            raise SystemExit(f"--also {item!r}: expected NAME=DIR with a new name (taken: {', '.join(NAMES.values())})")
        dirs = [Path(folder) / f"seed_{s}" for s in seeds]
        unfinished = [str(d) for d in dirs if not _finished(d)]
        if unfinished:
            raise SystemExit(f"--also {name}: no finished run in {', '.join(unfinished)}")
        FAMILY_NAMES[name] = NAMES[name] = name
        policy_file = "model.zip" if args.also_final else POLICY_FILE
        also[name] = {"train_args": f"finished runs in {folder}, not trained here ({policy_file})",
                      "seeds": [seed_record(d, s, policy_file) for d, s in zip(dirs, seeds)]}
    for method in [m for m in args.methods if m != BC]:
        extra = SMOKE_ARGS[method] if args.smoke else (["--hp", *METHOD_HP[method]] if method in METHOD_HP else [])
        record["methods"][method] = {"train_args": extra, "seeds": [train_seed(method, s, runs, extra) for s in seeds]}
    record["methods"].update(also)
    if BC in args.methods:
        record["bc"] = train_bc(seeds, runs, task_ids, args.smoke)
    if not args.train_only:
        for task_id in task_ids:
            print(f"evaluating on {task_id}", flush=True)
            record["evaluation"][task_id] = evaluate_task(task_id, record["methods"], out / "learned_baselines",
                                                          record.get("bc"), out / ABLATION_DIR, tuple(also))
    record["machine"]["load_at_end"] = os.getloadavg()
    (path := out / "learned_baselines.json").write_text(json.dumps(record, indent=1, default=str) + "\n")
    print(f"wrote {path}", flush=True)
    for method, r in record["methods"].items():
        rates = [s["steps_per_s"] for s in r["seeds"]]
        print(f"{method}: steps/s per seed {rates}", flush=True)
    for task_id, ev in record["evaluation"].items():
        for method, m in ev["methods"].items():
            print(f"{task_id} {method}: score IQM {m['score_iqm']} {m['score_ci95']}, frontier ratio IQM "
                  f"{m['frontier_ratio_iqm']} {m['frontier_ratio_ci95']}, safety cost IQM {m['safety_cost_s_iqm']}",
                  flush=True)
    if (curves := learning_curves(record["methods"], out / "learned_baselines_curves.png")) is not None:
        print(f"wrote {curves}", flush=True)
    if record["evaluation"]:
        (out / "learned_baselines.md").write_text(table(record))
        print(f"wrote {out / 'learned_baselines.md'}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
