#!/usr/bin/env python
"""Evaluate energy-management strategies on the hybrid bus.

Subcommands::

    python evaluate.py benchmark --out DIR        # the main job: strategies x cycles x scenarios, table + plots
    python evaluate.py run --cycle hwfet --strategy ecms [--json PATH --trace PATH --plot PATH]
    python evaluate.py paper --out DIR            # the paper reproduction report
    python evaluate.py performance --json PATH    # top speed, 0-60 km/h, 4 % grade (paper Table 3)

``python evaluate.py SUBCOMMAND --help`` lists every option. Errors in the input are reported in
one line with a non-zero exit status.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# subcommand name -> module providing add_parser(subparsers) and main(args) -> int
SUBCOMMANDS = {
    "benchmark": "agents.cli_benchmark",
    "run": "agents.cli_run",
    "paper": "agents.cli_paper",
    "performance": "hev_thermal_env.commands.performance",
}


def build_parser() -> tuple[argparse.ArgumentParser, dict]:
    parser = argparse.ArgumentParser(prog="evaluate.py", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND")
    sub.required = True
    modules = {}
    for name, module_name in SUBCOMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue
        module.add_parser(sub)
        modules[name] = module
    return parser, modules


def main(argv: list[str] | None = None) -> int:
    parser, modules = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(modules[args.command].main(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, NotADirectoryError, PermissionError, IsADirectoryError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
