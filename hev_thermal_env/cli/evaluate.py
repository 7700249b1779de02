"""Evaluate energy-management strategies on the hybrid bus.

The program behind ``evaluate.py`` and the ``hev-evaluate`` command. Subcommands::

    python evaluate.py benchmark --out DIR        # the main job: strategies x cycles x scenarios, table + plots
    python evaluate.py run --cycle hwfet --strategy ecms [--json PATH --trace PATH --plot PATH]
    python evaluate.py paper --out DIR            # the paper reproduction report
    python evaluate.py performance --json PATH    # top speed, 0-60 km/h, 4 % grade (paper Table 3)

``python evaluate.py SUBCOMMAND --help`` lists every option. Errors in the input, and output paths
that cannot be written (checked before any work), are reported in one line with a non-zero exit status.
"""

from __future__ import annotations

import argparse
import sys

from . import benchmark, paper, performance, run
from .errors import EXIT_INTERRUPTED, USER_ERRORS, program_name, report

#: subcommand name -> module providing add_parser(subparsers) and main(args) -> int
SUBCOMMANDS = {"benchmark": benchmark, "run": run, "paper": paper, "performance": performance}


def build_parser(prog: str = "evaluate.py") -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND")
    sub.required = True
    for module in SUBCOMMANDS.values():
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser(program_name(argv, "evaluate.py")).parse_args(argv)
    try:
        return int(SUBCOMMANDS[args.command].main(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except USER_ERRORS as exc:
        return report(exc)


if __name__ == "__main__":
    sys.exit(main())
