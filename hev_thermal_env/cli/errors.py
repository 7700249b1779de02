"""The name a command-line program was called by, and its one-line reports (:func:`run_program`).

Problems with the input are ``ValueError`` s, problems with files ``OSError`` s: either is one line,
without a traceback, exit status 2. Warnings are one ``warning:`` line each. Ctrl-C is one line,
``interrupted`` (with what was saved, if anything), exit status 130, wherever it arrives (:class:`KeptInterrupts`).
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path

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
