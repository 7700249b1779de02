"""What the programs share: the name a program was called by, its one-line reports (:func:`run_program`), and its
argument parsing (:class:`OneLineErrorParser`, :class:`HelpFormatter`, the run options of :func:`add_run_options`).

Problems with the input are ``ValueError`` s, problems with files ``OSError`` s: either is one line,
without a traceback, exit status 2. Warnings are one ``warning:`` line each. Ctrl-C is one line,
``interrupted`` (with what was saved, if anything), exit status 130, wherever it arrives (:class:`KeptInterrupts`).
"""

from __future__ import annotations

import _thread
import argparse
import os
import signal
import sys
import textwrap
import threading
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.cycles import list_cycles, list_families
from hev_thermal_env.scenarios import list_scenarios

#: Exceptions that mean "the input is wrong", reported in one line.
USER_ERRORS = (ValueError, OSError)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: Packages whose Python code a Ctrl-C must not cut short: llvmlite, LLVM's binding that numba's compiler drives
#: (see :class:`KeptInterrupts`).
UNINTERRUPTIBLE_PACKAGES = ("llvmlite",)
#: Seconds after which a Ctrl-C put off is delivered again.
REDELIVER_S = 0.05


def program_name(argv: list[str] | None, default: str) -> str:
    """The name the program was called by; ``default`` when ``main`` is given its arguments (called in-process)."""
    return Path(sys.argv[0]).name if argv is None and sys.argv and sys.argv[0] else default


def one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line; an ``OSError`` from the system names its file and the reason."""
    if isinstance(exc, OSError) and exc.strerror and exc.filename is not None:
        where = f"{exc.filename} -> {exc.filename2}" if exc.filename2 is not None else str(exc.filename)
        return f"{where}: {exc.strerror.lower()}"
    return " ".join(str(exc).split()) or type(exc).__name__


def report(exc: BaseException, prog: str | None = None) -> int:
    """Print ``error: MESSAGE`` (``PROG: error: MESSAGE`` with ``prog``) on stderr; returns the exit status."""
    print(f"{f'{prog}: ' if prog else ''}error: {one_line(exc)}", file=sys.stderr)
    return EXIT_USER_ERROR


def run_program(body: Callable[[], int | None], prog: str | None = None,
                errors: tuple[type[BaseException], ...] = USER_ERRORS) -> int:
    """``body()`` with the one-line reports of the module docstring (``PROG: `` before them with ``prog``); returns
    the exit status. A ``KeyboardInterrupt`` carrying a message (what was saved) prints it after ``interrupted:``."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"{f'{prog}: ' if prog else ''}warning: {' '.join(str(message).split())}", file=file or sys.stderr)

    try:
        with warnings.catch_warnings(), KeptInterrupts():
            warnings.showwarning = show
            return int(body() or 0)
    except KeyboardInterrupt as exc:
        print(f"interrupted: {one_line(exc)}" if str(exc) else "interrupted", file=sys.stderr)
        return int(getattr(exc, "exit_code", EXIT_INTERRUPTED))
    except errors as exc:
        return report(exc, prog)


class KeptInterrupts:
    """Within the block (in the main thread), a Ctrl-C is never lost, nor does it cut LLVM's bookkeeping short.

    Inside a function called from C (a ctypes callback, a finalizer) a ``KeyboardInterrupt`` cannot propagate: Python
    prints "Exception ignored" and the program never learns of the Ctrl-C. numba's compiler drives llvmlite, whose
    JIT calls back into Python for every function compiled (cut short, numba's cache write fails later) and whose
    wrappers note who owns an LLVM object right after the C call that hands it over (cut short in between, the object
    is freed twice and the interpreter crashes as it exits). So a Ctrl-C that arrives in code of
    :data:`UNINTERRUPTIBLE_PACKAGES`, or is dropped in any other call from C (``sys.unraisablehook``), is delivered
    again every :data:`REDELIVER_S` seconds until it lands outside; one still put off when the block ends raises there.
    """

    def __enter__(self) -> KeptInterrupts:
        self.active = (threading.current_thread() is threading.main_thread()
                       and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
        self.timer: threading.Timer | None = None
        self.put_off = False
        if self.active:
            self.previous_hook = sys.unraisablehook
            signal.signal(signal.SIGINT, self.interrupt)
            sys.unraisablehook = self.unraisable
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if self.active:
            if self.timer is not None:
                self.timer.cancel()
            signal.signal(signal.SIGINT, signal.default_int_handler)
            sys.unraisablehook = self.previous_hook
            if self.put_off and exc_type is None:
                raise KeyboardInterrupt

    def interrupt(self, signum: int, frame) -> None:
        """The SIGINT handler: ``KeyboardInterrupt``, unless a frame of the stack runs code of
        :data:`UNINTERRUPTIBLE_PACKAGES`."""
        folders = tuple(os.path.dirname(module.__file__) + os.sep for module in map(sys.modules.get,
                        UNINTERRUPTIBLE_PACKAGES) if module is not None and module.__file__)
        while frame is not None:
            if folders and frame.f_code.co_filename.startswith(folders):
                self.deliver_again()
                return
            frame = frame.f_back
        self.put_off = False
        raise KeyboardInterrupt

    def unraisable(self, info) -> None:  # sys.unraisablehook
        if isinstance(info.exc_value, KeyboardInterrupt):
            self.deliver_again()
        else:
            self.previous_hook(info)

    def deliver_again(self) -> None:
        """A Ctrl-C in the main thread :data:`REDELIVER_S` from now (from another thread, once it has moved on)."""
        self.put_off = True
        self.timer = threading.Timer(REDELIVER_S, _thread.interrupt_main)
        self.timer.daemon = True
        self.timer.start()


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
