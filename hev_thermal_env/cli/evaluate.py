"""Evaluate energy-management strategies on the hybrid bus.

The program behind ``evaluate.py`` and ``hev-evaluate``, one subcommand per job (:data:`SUBCOMMANDS`).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .errors import HelpFormatter, OneLineErrorParser, examples, program_name, report, run_program

#: The subcommands and the module of this package that holds each (in its ``COMMANDS[name]``: help, description,
#: examples, ``add_arguments(parser)``, ``main(args) -> int``), imported by :func:`build_parser` (so that a Ctrl-C
#: while they load is reported in one line).
SUBCOMMANDS = {"benchmark": "run", "run": "run", "paper": "run", "performance": "run", "reference": "tasks",
               "dataset": "tasks", "bc": "tasks", "leaderboard": "tasks"}

EXAMPLES = (
    "python evaluate.py benchmark --out results                  # shipped PPO + classic strategies",
    "python evaluate.py benchmark --scenarios paper hot --strategies rule dp dp_thermal ppo:runs/ppo",
    "python evaluate.py benchmark --task bus-generalisation --out results_gen   # a named task (hev_thermal_env.tasks)",
    "python evaluate.py run --cycle hwfet --strategy ecms --json r.json --trace r.csv --plot r.png",
    "python evaluate.py paper --out results/paper",
    "python evaluate.py performance --initial-motor-temp-c 50 --coolant off",
    "python evaluate.py leaderboard --out docs/leaderboard.md",
)


def build_parser(prog: str = "evaluate.py") -> argparse.ArgumentParser:
    epilog = examples(EXAMPLES) + "\n\nevery subcommand's options: python evaluate.py SUBCOMMAND --help"
    parser = OneLineErrorParser(prog=prog, description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter,
                                epilog=epilog)
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND")  # subparsers: OneLineErrorParser too
    sub.required = True
    for name, module in SUBCOMMANDS.items():
        text, description, lines, add, main = importlib.import_module(f"{__package__}.{module}").COMMANDS[name]
        p = sub.add_parser(name, help=text, description=description, formatter_class=HelpFormatter,
                           epilog=examples(lines))
        add(p)
        p.set_defaults(main=main)
    return parser


def main(argv: list[str] | None = None) -> int:
    def body() -> int:
        args = build_parser(program_name(argv, "evaluate.py")).parse_args(argv)
        from hev_thermal_env.evaluation.executors import ExecutorError

        try:
            return args.main(args)
        except ExecutorError as exc:  # Ray missing, a cluster unreachable: one line too
            return report(exc)

    return run_program(body)


if __name__ == "__main__":
    sys.exit(main())
