"""The name a command-line program was called by, and its one-line error reports.

Problems with the input (unknown names, malformed files, out-of-range values) are ``ValueError`` s;
problems with files (missing, not a directory, read-only file system, no permission) are
``OSError`` s. Either is printed as one line, without a traceback, with exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: Exceptions that mean "the input is wrong", reported in one line.
USER_ERRORS = (ValueError, OSError)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


class OneLineErrorParser(argparse.ArgumentParser):
    """Usage errors in one line (``train.py: error: ...``), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


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
