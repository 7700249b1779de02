"""One stage of the thermal optimum's search (:mod:`.optimum_search`): every surviving state expanded by every
split in batched physics calls, on threads, into arrays kept from stage to stage."""

from __future__ import annotations

import numpy as np

from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.door_arrays import MIN_THREAD_BATCH, thread_pool

from .common import stage_cost_g
from .dp_grid import DPProblem

__all__ = ["StageBuffers", "expand"]


def _chunks(n: int, threads: int) -> list[tuple[int, int]]:
    parts = threads if n >= MIN_THREAD_BATCH and threads > 1 else 1
    edges = np.linspace(0, n, parts + 1).astype(int)
    return [(int(edges[j]), int(edges[j + 1])) for j in range(parts)]


class StageBuffers:
    """Arrays of a stage's candidates, kept from stage to stage (grown when a stage has more rows): allocating
    and zero-filling hundreds of MB every stage costs as much as the physics. Inputs that are the same for every
    row (conditions, the state before the step as far as the cost reads it) are filled once."""

    def __init__(self, problem: DPProblem):
        self.problem, self.rows = problem, 0

    def get(self, rows: int) -> StageBuffers:
        if rows > self.rows:
            n = max(rows, int(self.rows * 1.5))
            p = self.problem
            self.so, self.out = np.empty((n, C.N_STATE)), np.empty((n, C.N_OUT))
            self.c, self.e, self.a = np.empty(n), np.empty(n), np.empty(n)
            self.v0, self.v1, self.g = np.empty(n), np.empty(n), np.empty(n)
            self.cond = np.ascontiguousarray(np.broadcast_to(p.cond, (n, p.cond.size)))
            self.before = np.zeros((n, C.N_STATE))
            self.before[:, C.SOC] = p.soc_target  # what stage_cost_g assumes without state_before
            self.target = np.full(n, float(p.soc_target))
            self.rows = n
        return self


def expand(problem: DPProblem, i: int, states: np.ndarray, cost: np.ndarray, batt_j: np.ndarray, u: np.ndarray,
            threads: int, buf: StageBuffers) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every state × every split of stage ``i``: next states, cost-to-come, battery energy and the splits (views of
    ``buf``, valid until the next stage).

    Row r is state r // m with split u[r % m]. Chunks of states run on separate threads, each doing
    its physics step and its cost (both compiled kernels release the GIL).
    """
    p, m = states.shape[0], u.size
    rows = p * m
    b = buf.get(rows)
    so, out, c, e, a = b.so[:rows], b.out[:rows], b.c[:rows], b.e[:rows], b.a[:rows]
    a.reshape(p, m)[:] = u
    v0, v1, g = (float(x[0]) for x in problem.stage_inputs(i, 1))
    rp, lhv, dt = problem.reward_params, problem.lhv, problem.core.dt_s

    def run(span: tuple[int, int]) -> None:
        lo, hi = span
        r = slice(lo * m, hi * m)
        b.v0[r], b.v1[r], b.g[r] = v0, v1, g
        problem.core.step(np.repeat(states[lo:hi], m, axis=0), a[r], b.v0[r], b.v1[r], b.g[r], b.cond[r],
                          state_out=so[r], out=out[r])
        c[r] = np.repeat(cost[lo:hi], m) + stage_cost_g(rp, out[r], so[r], b.target[r], lhv, dt, battery=False,
                                                         overheat=True, state_before=b.before[r])
        e[r] = np.repeat(batt_j[lo:hi], m) + out[r, C.BATT_CHEM] * dt

    spans = _chunks(p, threads) if rows >= MIN_THREAD_BATCH else [(0, p)]
    if len(spans) == 1:
        run(spans[0])
    else:
        list(thread_pool(len(spans)).map(run, spans))
    return so, c, e, a
