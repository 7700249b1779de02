"""``evaluate.py reference``: (re)compute a named task's reference values (the optimum's and ``engine_only``'s runs
per episode, the safety budget) and store them where the score and the leaderboard read them."""

from __future__ import annotations

import argparse
from pathlib import Path

from hev_thermal_env.evaluation.references import (
    BUDGET_RULE,
    REFERENCE_DIR,
    StaleReferenceError,
    compute_reference,
    load_reference,
    references_table,
    save_reference,
    write_references_table,
)
from hev_thermal_env.tasks import get_task, list_tasks

EXAMPLES = (
    "python evaluate.py reference --task hwfet               # recompute and store hwfet-v1's reference",
    "python evaluate.py reference --task hwfet beijing --check   # say whether the stored ones are current",
    "python evaluate.py reference --task bus-generalisation --jobs 2   # 18 routes, two solved at a time",
    "python evaluate.py reference --table docs/tasks.md   # the stored references as a table, into the docs",
)

HELP = "a task's reference values: r0, the optimum's cost, the safety budget"
DESCRIPTION = ("Run the thermal optimum and engine_only on every episode of a named task and "
               "store their costs, final SOCs, safety costs and the optimum's frontier with the "
               f"physics fingerprint and the task's digest; safety budget: {BUDGET_RULE}.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--task", nargs="+", metavar="NAME", help=f"tasks ({', '.join(list_tasks())})")
    p.add_argument("--dir", default=None, metavar="DIR", help=f"where references are kept (default: {REFERENCE_DIR})")
    p.add_argument("--check", action="store_true", help="only check the stored references (exit 1 if one is stale)")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="episodes solved at once, each in its own process on one thread (default 1)")
    p.add_argument("--table", nargs="?", const="-", default=None, metavar="FILE",
                   help="print the stored references of --task (default: every task) as a Markdown table, or put it "
                        "in FILE between the lines <!-- references:begin --> and <!-- references:end -->")


def main(args: argparse.Namespace) -> int:
    directory = Path(args.dir) if args.dir else None
    if args.table is not None:
        table = references_table(args.task, directory)
        if args.table == "-":
            print(table, end="")
        else:
            write_references_table(Path(args.table), table)
            print(f"wrote the references table to {args.table}")
        return 0
    if not args.task:
        raise ValueError("reference: --task NAME [NAME ...] is needed (unless --table)")
    if args.jobs < 1:
        raise ValueError(f"reference: --jobs must be at least 1, got {args.jobs}")
    tasks = [get_task(t) for t in args.task]
    if args.check:
        stale = 0
        for task in tasks:
            try:
                ref = load_reference(task, directory)
                print(f"{task.id}: current (budget {ref['safety_budget_s']:g} s, {len(ref['episodes'])} episodes)")
            except (FileNotFoundError, StaleReferenceError) as exc:
                stale += 1
                print(f"{task.id}: {exc}")
        return 1 if stale else 0
    for task in tasks:
        record = compute_reference(task, progress=print, jobs=args.jobs)
        path = save_reference(record, directory)
        print(f"{task.id}: safety budget {record['safety_budget_s']:g} s; wrote {path} ({record['wall_s']:.0f} s)")
    return 0
