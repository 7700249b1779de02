"""The local executor's worker processes end with the command: a SIGTERM to the command (``kill``, a scheduler's time
limit) stops the cells in progress instead of leaving them running without a parent."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SLOW = """
import os, time
from pathlib import Path

def slow(task):
    Path(task).write_text(str(os.getpid()))
    time.sleep(300)
    return task
"""

COMMAND = """
import sys
from hev_thermal_env.evaluation.executors import LocalExecutor
from slow import slow

if __name__ == "__main__":
    with LocalExecutor(2) as executor:
        for _ in executor.map(slow, sys.argv[1:], [0, 1], tick_s=0.2):
            pass
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_sigterm_stops_the_workers_and_ends_the_command_as_sigterm_does(tmp_path):
    (tmp_path / "slow.py").write_text(SLOW)
    (tmp_path / "command.py").write_text(COMMAND)
    marks = [tmp_path / "a.pid", tmp_path / "b.pid"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}
    proc = subprocess.Popen([sys.executable, str(tmp_path / "command.py"), *map(str, marks)], cwd=tmp_path, env=env)
    try:
        deadline = time.monotonic() + 120
        while not all(m.exists() and m.read_text() for m in marks) and time.monotonic() < deadline:
            time.sleep(0.1)
        workers = [int(m.read_text()) for m in marks]
        assert all(_alive(pid) for pid in workers)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == -signal.SIGTERM
        deadline = time.monotonic() + 10
        while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(_alive(pid) for pid in workers), workers
    finally:
        proc.kill()
        for m in marks:
            if m.exists() and m.read_text() and _alive(int(m.read_text())):
                os.kill(int(m.read_text()), signal.SIGKILL)


def test_the_executor_gives_back_the_sigterm_handler_it_found():
    from hev_thermal_env.evaluation.executors import LocalExecutor

    before = signal.getsignal(signal.SIGTERM)
    with LocalExecutor(2):
        assert signal.getsignal(signal.SIGTERM) is not before
    assert signal.getsignal(signal.SIGTERM) is before
    with LocalExecutor(1):
        assert signal.getsignal(signal.SIGTERM) is before


def test_a_sigterm_handler_of_the_program_still_runs_and_is_kept():
    """Where the program has its own SIGTERM handler, the executor stops its workers and then hands the signal on;
    the program's handler stays in place after the block."""
    import threading

    from hev_thermal_env.evaluation.executors import LocalExecutor

    seen: list[int] = []
    before = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    try:
        mine = signal.getsignal(signal.SIGTERM)
        with LocalExecutor(2):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)
            assert seen == [signal.SIGTERM]
            assert signal.getsignal(signal.SIGTERM) is mine
        assert signal.getsignal(signal.SIGTERM) is mine

        def in_a_thread():
            with LocalExecutor(2):
                seen.append(signal.getsignal(signal.SIGTERM) is mine)

        thread = threading.Thread(target=in_a_thread)
        thread.start()
        thread.join()
        assert seen[-1] is True  # outside the main thread nothing is installed
    finally:
        signal.signal(signal.SIGTERM, before)
