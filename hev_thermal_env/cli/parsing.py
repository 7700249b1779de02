"""Argument parsing shared by the programs: usage errors in one line (:class:`OneLineErrorParser`, inherited
by subcommand parsers), help texts that show every default (:class:`HelpFormatter`), and the options of a
training run that ``train.py`` and ``train.py sweep`` share (:func:`add_run_options`).
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Sequence
from typing import Any

from hev_thermal_env.cycles import list_cycles, list_families
from hev_thermal_env.scenarios import list_scenarios


class OneLineErrorParser(argparse.ArgumentParser):
    """Usage errors in one line (``PROG: error: MESSAGE (see --help)``), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """``(default: VALUE)`` after options with a value default whose help does not say it; descriptions and epilogs
    wrapped by paragraph, except those with indented lines (examples)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (not action.option_strings or "default" in text or default is None or default is False
                or default is argparse.SUPPRESS or default == []):
            return text
        shown = " ".join(str(v) for v in default) if isinstance(default, (list, tuple)) else str(default)
        return f"{text} (default: {shown.replace('%', '%%')})"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = []
        for par in text.split("\n\n"):
            lines = par.splitlines()
            if any(line[:1].isspace() for line in lines[1:]):
                paragraphs.append("\n".join(indent + line for line in lines))
            else:
                paragraphs.append(textwrap.fill(" ".join(par.split()), width, initial_indent=indent,
                                                subsequent_indent=indent))
        return "\n\n".join(paragraphs)


def examples(lines: Sequence[str]) -> str:
    """An epilog of example command lines."""
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)


#: Options of a training run or sweep that are not among its settings (``--resume`` keeps them).
SESSION_FLAGS = ("resume", "no_progress", "quiet", "address", "cpus", "export")


def refuse_settings_with_resume(args: argparse.Namespace, settings_file: str) -> None:
    """``--resume DIR`` takes every setting from ``DIR/settings_file``: an error naming the setting options given."""
    given = [f"--{k.replace('_', '-')}" for k, v in vars(args).items() if v is not None and k not in SESSION_FLAGS]
    if given:
        raise ValueError(f"--resume takes every setting from {args.resume}/{settings_file}; drop {' '.join(given)}")


def file_defaults() -> dict[str, dict[str, Any]]:
    """The run settings of each algorithm's hyperparameter file (what the options default to), by algorithm."""
    from hev_thermal_env.agents.policy_files import ALGORITHMS
    from hev_thermal_env.training.config import EVAL_DEFAULTS
    from hev_thermal_env.training.hyperparams import load_hyperparams

    out = {}
    for algo in ALGORITHMS:
        hp = load_hyperparams(algo)
        env, ev = hp.get("env") or {}, hp.get("eval") or {}
        out[algo] = {"cycles": " ".join(map(str, env.get("cycles", []))), "scenario": env.get("scenario"),
                     "timesteps": hp.get("n_timesteps"), "n_envs": hp.get("n_envs"),
                     "eval_cycles": " ".join(map(str, ev.get("cycles", EVAL_DEFAULTS["cycles"]))),
                     "eval_scenarios": " ".join(map(str, ev.get("scenarios", EVAL_DEFAULTS["scenarios"]))),
                     "eval_freq": ev.get("freq"), "checkpoint_freq": hp.get("checkpoint_freq")}
    return out


def per_algo(defaults: dict[str, dict[str, Any]], key: str) -> str:
    """``default from the hyperparameter file: VALUE (ppo), VALUE (sac)`` for the setting ``key``."""
    values = [f"{value[key]} ({algo})" for algo, value in defaults.items()]
    return "default from the hyperparameter file: " + ", ".join(values)


def add_run_options(p: argparse.ArgumentParser) -> dict[str, dict[str, Any]]:
    """The options of a run's training and evaluation (a sweep's trials too); returns :func:`file_defaults`."""
    d = file_defaults()
    p.add_argument("--algo", default=None, help=f"algorithm: {' or '.join(d)} (default: ppo)")
    p.add_argument("--cycles", nargs="+", default=None, metavar="CYCLE",
                   help=f"training cycles: cycle families ({', '.join(list_families())}: a fresh generated cycle "
                        f"per episode), built-in names ({', '.join(list_cycles())}), FAMILY:SEED or CSV paths; "
                        f"{per_algo(d, 'cycles')}")
    p.add_argument("--scenario", default=None, metavar="S",
                   help=f"one of {', '.join(list_scenarios())}; {per_algo(d, 'scenario')}")
    p.add_argument("--timesteps", type=int, default=None, metavar="N",
                   help=f"total env-steps; {per_algo(d, 'timesteps')}")
    p.add_argument("--n-envs", type=int, default=None, metavar="N",
                   help=f"parallel environments; {per_algo(d, 'n_envs')}")
    p.add_argument("--hp", nargs="+", action="extend", default=None, metavar="KEY=VALUE",
                   help="hyperparameter overrides: YAML values, dotted keys reach inside mappings; --hp may be "
                        "repeated")
    p.add_argument("--hyperparams", default=None, metavar="FILE",
                   help="hyperparameter YAML file (default: agents/hyperparams/<algo>.yaml)")
    p.add_argument("--eval-cycles", nargs="*", default=None, metavar="CYCLE",
                   help=f"evaluation cycles the checkpoints are scored on, not trained on (validation_bus:A..B: "
                        f"validation cycles A to B); none (or no CYCLE) disables evaluation; "
                        f"{per_algo(d, 'eval_cycles')}")
    p.add_argument("--eval-scenarios", nargs="+", default=None, metavar="S",
                   help=f"evaluation scenarios; {per_algo(d, 'eval_scenarios')}")
    p.add_argument("--eval-freq", type=int, default=None, metavar="N",
                   help=f"evaluate every N env-steps; {per_algo(d, 'eval_freq')}")
    return d


def eval_cycles(args: argparse.Namespace) -> list[str] | None:
    """``--eval-cycles``: ``none`` (or no cycle) is no evaluation, not a cycle called none."""
    return [] if args.eval_cycles == ["none"] else args.eval_cycles
