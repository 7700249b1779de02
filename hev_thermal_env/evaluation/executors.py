"""Where the cells of a benchmark matrix run: this machine's processes (``local``) or Ray tasks (``ray``, the optional
``ray`` extra; docs/scaling-out.md). An executor's ``map`` yields ``(index, result)`` as the cells finish, and
``None`` every ``tick_s`` seconds without one (so a Ctrl-C is handled within that time); ``slots`` is how many run at
once. Ray missing, or no cluster at the address, raises :class:`ExecutorError` in one line.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import socket
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

EXECUTORS = ("local", "ray")
RAY_INSTALL = 'pip install "hev-thermal-env[ray]" (in a source tree: pip install -e ".[ray]")'
#: Seconds to wait for a TCP answer from ``--address`` before giving up.
CONNECT_TIMEOUT_S = 5.0
#: Port of a Ray head's GCS when the address names only a host.
DEFAULT_RAY_PORT = 6379
#: Times a cell is run again after its worker process died.
MAX_RETRIES = 3


class ExecutorError(RuntimeError):
    """The executor cannot run: Ray missing, a cluster unreachable, a cell lost after every retry."""


def import_ray():
    """The ``ray`` module, or :class:`ExecutorError` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise ExecutorError(f"--executor ray needs Ray, which is not installed: {RAY_INSTALL}") from None
    return ray


def make_executor(name: str, *, jobs: int = 1, address: str | None = None):
    """The executor called ``name`` (``local`` or ``ray``); checks what it needs before any work."""
    if name == "local" and address is not None:
        raise ValueError("--address needs --executor ray")
    if name not in EXECUTORS:
        raise ValueError(f"unknown executor {name!r}; choose one of {', '.join(EXECUTORS)}")
    return LocalExecutor(jobs) if name == "local" else RayExecutor(jobs, address)


class LocalExecutor:
    """Cells in this process (``jobs=1``) or in ``jobs`` spawned processes. The workers ignore Ctrl-C, so only this
    process reports it; leaving on an exception, or a SIGTERM, stops the workers, not waiting for them."""

    def __init__(self, jobs: int = 1):
        self.jobs = self.slots = max(1, int(jobs))
        self.pool: ProcessPoolExecutor | None = None
        self.others: set = set()
        self.sigterm: Any = None

    def __enter__(self) -> LocalExecutor:
        if self.jobs > 1:
            self.others = set(multiprocessing.active_children())  # child processes that are not the workers
            # spawn, not fork: a forked child would inherit the parent's thread pools (DP) mid-lock
            self.pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=multiprocessing.get_context("spawn"))
            self._catch_sigterm()
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=exc_type is None, cancel_futures=True)
            if exc_type is not None:  # interrupted or failed: stop the cells in progress rather than wait for them
                self._stop_workers()
            self.pool = None
        if self.sigterm is not None:
            signal.signal(signal.SIGTERM, self.sigterm)
            self.sigterm = None

    def _stop_workers(self) -> None:
        for worker in set(multiprocessing.active_children()) - self.others:
            worker.terminate()

    def _catch_sigterm(self) -> None:
        """Until :meth:`__exit__`, a SIGTERM first stops the workers (spawned processes outlive a parent killed
        without its cleanup), then does what it did before. Only in the main thread, where it is not ignored."""
        if threading.current_thread() is not threading.main_thread():
            return
        previous = signal.getsignal(signal.SIGTERM)
        if previous is signal.SIG_IGN or previous is None:
            return

        def on_sigterm(signum: int, frame: Any) -> None:
            self._stop_workers()
            signal.signal(signal.SIGTERM, previous)
            self.sigterm = None
            if callable(previous):
                previous(signum, frame)
            else:
                os.kill(os.getpid(), signal.SIGTERM)

        self.sigterm = previous
        signal.signal(signal.SIGTERM, on_sigterm)

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], order: Sequence[int],
            tick_s: float | None = None) -> Iterator[tuple[int, Any] | None]:
        """``(i, fn(tasks[i]))`` for every ``i`` of ``order`` (submitted in that order) as they finish (module
        docstring); in this process, nothing while a cell runs."""
        if self.pool is None:
            yield from ((i, fn(tasks[i])) for i in order)
            return
        # the workers start within, SIGINT ignored: they ignore it for life (an inherited ignored SIGINT is kept)
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            futures = {self.pool.submit(fn, tasks[i]): i for i in order}
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=tick_s, return_when=FIRST_COMPLETED)
            if not done:
                yield None
            for future in sorted(done, key=futures.__getitem__):
                yield futures[future], future.result()


class RayExecutor:
    """One Ray task (one CPU) per cell, on a local runtime of ``jobs`` CPUs or the cluster at ``address`` (every CPU
    it has). A cell whose worker process dies is run again on another, up to :data:`MAX_RETRIES` times (the cells are
    deterministic)."""

    def __init__(self, jobs: int = 1, address: str | None = None):
        self.ray = import_ray()
        self.jobs = self.slots = max(1, int(jobs))
        self.address = address
        self.started = False

    def __enter__(self) -> RayExecutor:
        self.started = start_ray(self.ray, self.jobs, self.address)
        self.slots = max(1, int(self.ray.cluster_resources().get("CPU", self.jobs)))
        return self

    def __exit__(self, *exc) -> None:
        if self.started:
            self.ray.shutdown()
            self.started = False

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], order: Sequence[int],
            tick_s: float | None = None) -> Iterator[tuple[int, Any] | None]:
        ray = self.ray
        remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(fn)
        pending = {remote.remote(tasks[i]): i for i in order}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=tick_s)
            if not ready:
                yield None
                continue
            i = pending.pop(ready[0])
            cell = "/".join(x for x in tasks[i] if isinstance(x, str))  # cycle/scenario/strategy
            try:
                result = ray.get(ready[0])
            except ray.exceptions.RayTaskError as exc:
                # the cell's own error (a ValueError from bad input...), as the local executor raises it
                if exc.cause is not None:
                    raise exc.cause from None
                raise ExecutorError(f"cell {cell} failed: {' '.join(str(exc).split())}") from None
            except ray.exceptions.RayError as exc:
                first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise ExecutorError(f"cell {cell} lost after {MAX_RETRIES} retries "
                                    f"({type(exc).__name__}: {first})") from None
            yield i, result


def start_ray(ray, num_cpus: int | None, address: str | None) -> bool:
    """Connect this process to Ray: a runtime already started here as it is, else a local runtime of ``num_cpus`` CPUs
    (all when None) or the cluster at ``address``; returns whether it started or joined one (to shut down later)."""
    if ray.is_initialized():
        return False
    kwargs: dict[str, Any] = dict(logging_level=logging.WARNING, log_to_driver=False, include_dashboard=False)
    if address is None:
        ray.init(num_cpus=num_cpus, **kwargs)
        return True
    if address.strip() != "auto":  # fail fast, in one line, when nothing answers there (``auto`` is left to Ray)
        host, port = split_address(address)
        try:
            socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
        except OSError as exc:
            reason = exc.strerror or str(exc) or type(exc).__name__
            raise ExecutorError(f"--address {address}: no Ray cluster reachable at {host}:{port} "
                                f"({reason.lower()}); start one with 'ray start --head' or check the address") from None
    try:
        ray.init(address=address, **kwargs)
    except Exception as exc:  # noqa: BLE001 - any failure to join is reported in one line
        raise ExecutorError(f"--address {address}: cannot join a Ray cluster there "
                            f"({' '.join(str(exc).split()) or type(exc).__name__})") from None
    return True


def split_address(address: str) -> tuple[str, int]:
    """``(host, port)`` of ``HOST[:PORT]`` or ``ray://HOST[:PORT]`` (port 6379, or 10001 for ``ray://``)."""
    text = address.strip()
    default = 10001 if text.startswith("ray://") else DEFAULT_RAY_PORT
    text = text.removeprefix("ray://")
    host, sep, port = text.rpartition(":") if ":" in text else (text, "", "")
    host = host.strip("[]")
    if not host:
        raise ExecutorError(f"--address {address!r}: expected HOST:PORT (e.g. 192.168.1.10:6379) or auto")
    if not sep:
        return host, default
    try:
        return host, int(port)
    except ValueError:
        raise ExecutorError(f"--address {address!r}: port {port!r} is not a number") from None

