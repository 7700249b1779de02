"""``evaluate.py bc``: behaviour cloning on an offline dataset, scored on tasks (the datasets' usability check)."""

from __future__ import annotations

import argparse
from pathlib import Path

from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.tasks import get_task, held_out_cycles, list_tasks

EXAMPLES = (
    "python evaluate.py dataset --source optimum --routes 4 --families bus_launch bus_hilly",
    "python evaluate.py bc --dataset hev-thermal/train-paper/optimum-v0 --tasks hwfet beijing "
    "--results-dir results/leaderboard_bc",
    "python evaluate.py leaderboard --results results/leaderboard_bc --out docs/leaderboard.md",
)

HELP = "behaviour cloning on a Minari dataset, scored on tasks"
DESCRIPTION = ("Fit a small MLP to a dataset's actions (once per seed) and write the seed "
               "family's result file on each task (RESULTS_DIR/<task>/bc.json) for the "
               "leaderboard. The dataset must come from training routes: one with a task's "
               "cycles is refused.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--dataset", required=True, metavar="ID", help="Minari dataset id (in $MINARI_DATASETS_PATH)")
    p.add_argument("--tasks", nargs="+", default=list_tasks(), metavar="NAME", help="tasks to score it on")
    p.add_argument("--epochs", type=int, default=60, help="passes over the dataset")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], metavar="SEED",
                   help="fit seeds, fixed in advance (default: 0); each fit is one member of the family")
    p.add_argument("--method", default="bc (optimum, training routes)", help="its name on the leaderboard")
    p.add_argument("--results-dir", default="results/leaderboard_bc", metavar="DIR")
    p.add_argument("--policy", default=None, metavar="FILE",
                   help="also save the policy here (.pt; with several seeds, FILE's stem gets _seedS)")


def main(args: argparse.Namespace) -> int:
    import minari

    from hev_thermal_env.evaluation.submission import result_of_seeds
    from hev_thermal_env.training.fit import BCStrategy, save_bc, train_bc

    meta = minari.load_dataset(args.dataset).storage.metadata
    held = held_out_cycles()
    seen = {str(e["cycle"]).lower() for e in meta.get("hev_thermal_episodes", [])}
    task_cycles = {c.lower() for t in list_tasks() for c in get_task(t).cycles}
    if meta.get("hev_thermal_task") or seen & (set(held) | task_cycles):
        raise ValueError(f"{args.dataset}: holds task or test cycles ({sorted(seen & (set(held) | task_cycles))[:3]} "
                         f"task {meta.get('hev_thermal_task')}); clone a dataset of training routes")
    if len(set(args.seeds)) != len(args.seeds):
        raise ValueError(f"--seeds: each seed once, got {args.seeds}")
    fits = []
    for seed in args.seeds:
        record, report = train_bc(args.dataset, epochs=args.epochs, seed=seed)
        print(f"seed {seed}: fitted on {report['pairs']} pairs in {report['wall_s']} s: MSE {report['mse_first']} -> "
              f"{report['mse_last']} (action variance {report['action_variance']})")
        if args.policy:
            path = Path(args.policy)
            save_bc(record, path if len(args.seeds) == 1 else path.with_name(f"{path.stem}_seed{seed}{path.suffix}"))
        fits.append((seed, BCStrategy(record, label=args.method), report))
    training = {"wall_clock_s_per_seed": [float(r["wall_s"]) for _, _, r in fits], "fits": [r for _, _, r in fits]}
    for name in args.tasks:
        task = get_task(name)
        result = result_of_seeds(task, {seed: strategy for seed, strategy, _ in fits}, args.method, training=training,
                                 track="guided")  # fitted to its dataset's actions alone
        path = atomic_write_json(Path(args.results_dir) / task.id / "bc.json", result)
        print(f"{task.id}: {len(result['episodes'])} episodes in {result['wall_clock_s']:.1f} s -> {path}")
    return 0
