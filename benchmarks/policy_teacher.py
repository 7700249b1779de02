"""The arguments of the diagnostics that set policies beside their teacher (``derating_diagnosis.py``,
``teacher_cost_gap.py``): ``--policy NAME=RUN_DIR_OR_ZIP`` (repeatable) and ``--teacher-options JSON``.

The teacher is ``ecms_thermal`` with the options the policies were fitted to (their run's ``init.teacher_options``),
or with ``--teacher-options``; policies fitted to different teachers, or to none, need ``--teacher-options``.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

TEACHER = "ecms_thermal"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``--policy`` and ``--teacher-options`` on ``p``."""
    p.add_argument("--policy", action="append", default=[], metavar="NAME=PATH", help="a policy of train.py")
    p.add_argument("--teacher-options", default=None, metavar="JSON",
                   help=f"{TEACHER}'s options (default: those the policies were fitted to)")


def named_policies(args: argparse.Namespace) -> list[tuple[str, str]]:
    """``--policy`` as (name, path) pairs, in order; at least one."""
    policies = [tuple(item.partition("=")[::2]) for item in args.policy]
    if not policies or any(not name or not path for name, path in policies):
        raise SystemExit("give at least one --policy NAME=RUN_DIR_OR_ZIP")
    return policies


def given_options(args: argparse.Namespace) -> dict[str, Any] | None:
    """``--teacher-options`` read as JSON, or None when not given."""
    if args.teacher_options is None:
        return None
    try:
        return json.loads(args.teacher_options)
    except ValueError as exc:
        raise SystemExit(f"--teacher-options is not JSON ({exc})") from None


def teacher_options(given: dict[str, Any] | None, strategies: dict[str, Any]) -> dict[str, Any]:
    """``given``, or the options of the teacher every policy of ``strategies`` (name: loaded ``ppo:`` strategy) was
    fitted to."""
    if given is not None:
        return given
    fitted = {}
    for name, strategy in strategies.items():
        init = strategy.policy.config.get("init") or {}
        if init.get("imitate") != TEACHER:
            raise SystemExit(f"--policy {name}: not fitted to {TEACHER}; give --teacher-options")
        fitted[name] = dict(init.get("teacher_options") or {})
    options = next(iter(fitted.values()))
    if any(o != options for o in fitted.values()):
        raise SystemExit(f"the policies were fitted to different teachers ({fitted}); give --teacher-options")
    return options
