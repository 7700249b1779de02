"""The name a command-line program was called by, and its one-line reports (:func:`run_program`).

Problems with the input are ``ValueError`` s, problems with files ``OSError`` s: either is one line,
without a traceback, exit status 2. Warnings are one ``warning:`` line each. Ctrl-C is one line,
``interrupted`` (with what was saved, if anything), exit status 130.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from pathlib import Path

#: Exceptions that mean "the input is wrong", reported in one line.
USER_ERRORS = (ValueError, OSError)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


def program_name(argv: list[str] | None, default: str) -> str:
    """The name the program was called by (``evaluate.py``, ``hev-evaluate``...); ``default`` when ``main``
    is given its arguments (called in-process)."""
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
    """``body()`` with the one-line reports of the module docstring (``PROG: `` before errors and warnings
    with ``prog``); returns the exit status. A ``KeyboardInterrupt`` carrying a message (what was saved)
    prints it after ``interrupted:``, and its ``exit_code`` if it has one."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"{f'{prog}: ' if prog else ''}warning: {' '.join(str(message).split())}", file=file or sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.showwarning = show
            return int(body() or 0)
    except KeyboardInterrupt as exc:
        print(f"interrupted: {one_line(exc)}" if str(exc) else "interrupted", file=sys.stderr)
        return int(getattr(exc, "exit_code", EXIT_INTERRUPTED))
    except errors as exc:
        return report(exc, prog)
