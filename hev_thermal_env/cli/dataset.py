"""``evaluate.py dataset``: an offline dataset (Minari) of a strategy's episodes on a task or on training routes."""

from __future__ import annotations

import argparse

from hev_thermal_env.evaluation.datasets import SOURCES, training_routes, write_dataset
from hev_thermal_env.tasks import TRAINING_FAMILIES, list_tasks

EXAMPLES = (
    "python evaluate.py dataset --source optimum --task hwfet          # hev-thermal/hwfet-v1/optimum-v0",
    "python evaluate.py dataset --source rule --routes 12 --root data/minari   # 12 training routes",
)

HELP = "a Minari dataset of a strategy's episodes (offline RL)"
DESCRIPTION = ("Drive a task's episodes (or generated training routes) with a source strategy "
               "through Minari's DataCollector and write the dataset, its card filled (physics "
               "fingerprint, task id and digest or the routes, each episode's reset arguments).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--source", required=True, choices=list(SOURCES), help="who drives (optimum = dp_thermal)")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--task", metavar="NAME", help=f"a task ({', '.join(list_tasks())})")
    where.add_argument("--routes", type=int, metavar="N", help="N generated routes of the training families")
    p.add_argument("--families", nargs="+", default=None, metavar="FAMILY",
                   help=f"with --routes: the families, in turn ({', '.join(TRAINING_FAMILIES)})")
    p.add_argument("--scenario", default="paper", help="with --routes: the scenario (default: paper)")
    p.add_argument("--root", default=None, metavar="DIR",
                   help="datasets directory (default: $MINARI_DATASETS_PATH, else ~/.minari/datasets)")
    p.add_argument("--name", default=None, metavar="ID", help="dataset id (default: hev-thermal/<task>/<source>-v0)")
    p.add_argument("--seed", type=int, default=0, help="the random source's seed")


def main(args: argparse.Namespace) -> int:
    if args.routes is not None and args.routes < 1:
        raise ValueError(f"--routes must be at least 1, got {args.routes}")
    routes = training_routes(args.routes, tuple(args.families or ())) if args.routes else None
    info = write_dataset(args.source, task=args.task, routes=routes, scenario=args.scenario, root=args.root,
                         seed=args.seed, dataset_name=args.name)
    print(f"{info['dataset_id']}: {info['episodes']} episodes, {info['steps']} steps, "
          f"{info['bytes'] / 1e6:.2f} MB in {info['path']} ({info['wall_s']:.1f} s)")
    return 0
