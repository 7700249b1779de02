"""``evaluate.py leaderboard``: every method on every task with references, one Markdown page and a profile plot."""

from __future__ import annotations

import argparse
from pathlib import Path

from hev_thermal_env.evaluation.leaderboard import (
    METHODS,
    PROFILE_FILE,
    ensure_results,
    missing_text,
    score_files,
    write_leaderboard,
)
from hev_thermal_env.evaluation.references import StaleReferenceError, load_reference
from hev_thermal_env.tasks import get_task, list_tasks

EXAMPLES = (
    "python evaluate.py leaderboard --out docs/leaderboard.md          # every task with references",
    "python evaluate.py leaderboard --results my_sac/ --out board.md    # with a method written elsewhere",
    "python evaluate.py leaderboard --tasks hwfet --methods rule ecms --results-dir /tmp/r --out /tmp/board.md",
)

HELP = "every method on every task: normalised score, safety cost, profile plot"
DESCRIPTION = ("Run this package's methods on every task that has current references (their "
               "result files are kept in --results-dir and reused), add the result files of "
               f"--results, and write the page --out with {PROFILE_FILE} beside it.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--tasks", nargs="+", default=None, metavar="NAME",
                   help="tasks (default: every task with a current reference)")
    p.add_argument("--methods", nargs="+", default=list(METHODS), metavar="STRATEGY",
                   help=f"this package's methods to run (default: {' '.join(METHODS)})")
    p.add_argument("--results", nargs="+", default=[], metavar="PATH",
                   help="more result files (or directories of them), e.g. of a method written elsewhere")
    p.add_argument("--results-dir", default="results/leaderboard", metavar="DIR",
                   help="where the package's methods' result files are kept")
    p.add_argument("--references", default=None, metavar="DIR", help="references directory (default: the package's)")
    p.add_argument("--out", default="docs/leaderboard.md", metavar="FILE", help="the page")
    p.add_argument("--no-plot", action="store_true", help=f"skip {PROFILE_FILE}")


def main(args: argparse.Namespace) -> int:
    refs = Path(args.references) if args.references else None
    names = [get_task(t).id for t in (args.tasks or list_tasks())]
    ready, missing = [], []
    for t in names:
        try:
            load_reference(t, refs)
            ready.append(t)
        except (FileNotFoundError, StaleReferenceError) as exc:
            if args.tasks:
                raise
            missing.append(missing_text(t, exc))
    paths = ensure_results(Path(args.results_dir), ready, args.methods, progress=print, references=refs)
    entries, more_missing = score_files([*paths, *args.results], refs)
    out = write_leaderboard(entries, [*missing, *more_missing], Path(args.out), plot=not args.no_plot)
    print(f"{len(entries)} results on {len({e['task'] for e in entries})} tasks; wrote {out}")
    for m in missing + more_missing:
        print(f"left out: {m}")
    return 0
