"""What happens during ``model.learn``: checkpoints, evaluation and stopping on a signal.

Interruption: SIGINT or SIGTERM stops training at the next step (the partial rollout is dropped);
the loop then saves a checkpoint and raises :class:`TrainingInterrupted`. A second SIGINT stops at
once (``KeyboardInterrupt``).
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback


class TrainingInterrupted(KeyboardInterrupt):
    """Training stopped on a signal after saving a checkpoint (``exit_code`` 130 for SIGINT, 143 for SIGTERM).

    A ``KeyboardInterrupt``, like the Ctrl-C it comes from: ``train.py`` reports it in one line."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


class RunCallback(BaseCallback):
    """Checkpoints, evaluation with best-model keeping, and stopping on a signal, in one callback.

    Checkpoints and evaluations happen at the start of a rollout, once ``model.num_timesteps``
    has crossed their next multiple of the frequency (in env-steps, so they hold across resumes):
    then every step counted has been trained on. A stop discards the partial rollout and sets the
    count back to its start, so a resumed run ends where an uninterrupted one would. ``run`` is the
    :class:`~hev_thermal_env.training.loop.TrainingRun` (its ``evaluate``, ``checkpoint`` and frequencies).
    """

    def __init__(self, run: Any):
        super().__init__()
        self.run = run
        self.stop_signal: int | None = None
        self.rollout_start = 0

    def _init_callback(self) -> None:
        n, r = int(self.model.num_timesteps), self.run
        self.rollout_start, self.next_ckpt = n, _next_multiple(n, r.checkpoint_freq)
        self.next_eval = _next_multiple(n, r.eval_freq) if r.eval_freq else math.inf

    def _on_rollout_start(self) -> None:
        n = int(self.model.num_timesteps)
        self.rollout_start = n
        if n >= self.next_eval:
            self.run.evaluate(self.model, self.logger)
            self.next_eval = _next_multiple(n, self.run.eval_freq)
        if n >= self.next_ckpt:
            self.run.checkpoint(self.model)
            self.next_ckpt = _next_multiple(n, self.run.checkpoint_freq)

    def _on_step(self) -> bool:
        if self.stop_signal is not None:
            self.model.num_timesteps = self.rollout_start
            return False
        return True


def _next_multiple(n: int, freq: int) -> int:
    return (int(n) // int(freq) + 1) * int(freq)


@contextlib.contextmanager
def stop_on_signals(callback: RunCallback):
    """SIGINT/SIGTERM ask ``callback`` to stop training at the next step; a second SIGINT stops at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        if callback.stop_signal is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        callback.stop_signal = signum

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
