"""The benchmark's progress bar: the runs in progress by name, and the time left weighted by each run's cost.

Runs differ in cost by four orders of magnitude (``dp_thermal`` searches for minutes unless its plan is on disk,
``dp`` for seconds, the others drive a cycle in a fraction of one), so the bar counts expected seconds, not runs
(:func:`expected_cost_s`); the time left is tqdm's, from the rate of that work so far.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from tqdm.auto import tqdm

#: Expected seconds of a run per second of cycle on one core, by strategy (the plan searches; dp_thermal: 0.03-0.12).
SECONDS_PER_STEP = {"dp_thermal": 0.06, "dp": 0.004}
#: The same for every other strategy (a drive through the cycle).
OTHER_SECONDS_PER_STEP = 1e-4
#: Expected seconds of a run besides its steps (building the strategy and the environment), by strategy: a
#: learned policy loads torch in its worker first.
OVERHEAD_S = {"ppo": 8.0}
OTHER_OVERHEAD_S = 0.2
#: A run in progress counts its elapsed time up to this fraction of its weight.
RUNNING_CREDIT = 0.9
BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]"


def expected_cost_s(strategy: str, n_steps: int) -> float:
    """Expected seconds of one run of ``strategy`` over a cycle of ``n_steps`` seconds, without a plan on disk."""
    base = strategy.split(":", 1)[0]
    return OVERHEAD_S.get(base, OTHER_OVERHEAD_S) + SECONDS_PER_STEP.get(base, OTHER_SECONDS_PER_STEP) * n_steps


class BenchmarkProgress:
    """A tqdm bar over runs ``labels`` of expected costs ``costs``, handed out in ``order`` to ``slots`` workers. A
    finished run adds its weight, a run in progress its elapsed time up to :data:`RUNNING_CREDIT` of its weight (a
    slower run weighs more as it goes); the postfix names the first ``slots`` unfinished runs in the order handed out
    (the workers take them first in, first out). Call :meth:`finished` when a run ends and :meth:`show` to redraw
    (every second or so, so that the elapsed times tick)."""

    def __init__(self, labels: Sequence[str], costs: Sequence[float], order: Sequence[int], slots: int,
                 enabled: bool = True):
        self.labels, self.costs = list(labels), [float(c) for c in costs]
        self.waiting = list(order)
        self.slots = max(1, int(slots))
        self.started: dict[int, float] = {}
        self.done_cost = 0.0
        self.bar = tqdm(total=sum(self.costs), desc="benchmark", disable=not enabled, smoothing=0,
                        bar_format=BAR_FORMAT)

    def __enter__(self) -> BenchmarkProgress:
        self.show()
        return self

    def __exit__(self, *exc) -> None:
        self.bar.close()

    def finished(self, i: int) -> None:
        self.waiting.remove(i)
        self.started.pop(i, None)
        self.done_cost += self.costs[i]

    def show(self) -> None:
        now = time.perf_counter()
        running = self.waiting[:self.slots]
        for i in running:
            self.started.setdefault(i, now)
        for i in running:  # a run that takes longer than expected is at most 90 % done
            self.costs[i] = max(self.costs[i], (now - self.started[i]) / RUNNING_CREDIT)
        self.bar.total = sum(self.costs)
        credit = sum(min(now - self.started[i], RUNNING_CREDIT * self.costs[i]) for i in running)
        work = self.done_cost + credit if self.waiting else self.bar.total
        self.bar.update(max(work - self.bar.n, 0.0))
        done = len(self.labels) - len(self.waiting)
        names = ", ".join(f"{self.labels[i]} {tqdm.format_interval(now - self.started[i])}" for i in running)
        self.bar.set_postfix_str(f"{done}/{len(self.labels)} runs done" + (f"; running {names}" if names else ""))
