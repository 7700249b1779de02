"""One stage of the thermal optimum's search (:mod:`.search`): every surviving state × every split, stepped by the
physics core and priced by the env's reward in one compiled call per thread.

Row r of a stage is state r // m with split r % m (m splits). The rows are cut into blocks of :data:`BLOCK_ROWS`; a
thread steps and prices its blocks inside :func:`expand_kernel`, with the env's own
:func:`~hev_thermal_env.physics.core.step_kernel` and :func:`~hev_thermal_env.envs.reward.reward_row`.
"""

from __future__ import annotations

import numpy as np

from hev_thermal_env.envs.reward import reward_row
from hev_thermal_env.physics.core import BATT_CHEM, N_OUT, N_STATE, SOC, step_kernel
from hev_thermal_env.physics.jit import MIN_THREAD_BATCH, jit, thread_pool

from .problem import DPProblem

#: Rows one thread steps and prices at a time, in scratch arrays reused block after block so that they stay in the
#: core's cache. Threads take the blocks in turn (block k to thread k mod threads), so a run of costly rows is shared.
BLOCK_ROWS = 4096


@jit
def expand_kernel(gl, dl, en, mo, th, ba, pt, dt, w, target, states, cost, batt_j, m, a, v0, v1, g, cond, before, x,
                  out, so, c, e, first, stride, per_block):
    """The blocks of states ``first``, ``first + stride``, ... (``per_block`` states each) of one stage.

    Per block: the states repeated once per split into ``x``, one physics step (``a``: the splits of every row of the
    stage), then each row's cost-to-come ``c`` (the parent's ``cost`` plus the reward's cost of the step with the
    weights ``w``, the band's center ``target`` before and after, ``before`` the state the cost takes as the one before
    the step) and battery energy ``e`` (the parent's ``batt_j`` plus the step's). ``so``, ``c``, ``e`` and ``a``
    have one row per row of the stage; ``x``, ``out``, ``v0``, ``v1``, ``g``, ``cond`` and ``before`` are the
    thread's scratch of at least ``per_block · m`` rows.
    """
    p = states.shape[0]
    n_state = states.shape[1]
    lo = first
    while lo < p:
        hi = min(lo + per_block, p)
        n = (hi - lo) * m
        r0 = lo * m
        for row in range(n):
            s = lo + row // m
            for k in range(n_state):
                x[row, k] = states[s, k]
        block = so[r0:r0 + n]
        step_kernel(gl, dl, en, mo, th, ba, pt, x[:n], a[r0:r0 + n], v0[:n], v1[:n], g[:n], cond[:n], dt, block,
                    out[:n])
        for row in range(n):
            s = lo + row // m
            total = reward_row(w, out, before, block, row, target, target, dt)[4]
            c[r0 + row] = -total + cost[s]
            e[r0 + row] = batt_j[s] + out[row, BATT_CHEM] * dt
        lo += stride


class _Scratch:
    """One thread's block of physics inputs and outputs; the inputs that are the same for every row (conditions, the
    state before the step as far as the cost reads it) are filled once."""

    def __init__(self, problem: DPProblem, n: int):
        self.x, self.out = np.empty((n, N_STATE)), np.empty((n, N_OUT))
        self.v0, self.v1, self.g = np.empty(n), np.empty(n), np.empty(n)
        self.cond = np.ascontiguousarray(np.broadcast_to(problem.cond, (n, problem.cond.size)), dtype=np.float64)
        self.before = np.zeros((n, N_STATE))
        self.before[:, SOC] = problem.soc_target  # the settlement's start: the band's center (the search charges
        # the band on the final SOC, :func:`~hev_thermal_env.envs.reward.soc_band_charge_g`)


class StageBuffers:
    """Arrays of a stage's candidates, kept from stage to stage (grown when a stage has more rows: allocating hundreds
    of MB every stage costs as much as the physics), each thread's scratch block, and the reward's ``weights`` of a
    stage's cost (the battery is priced by the bins and the band on the final SOC)."""

    def __init__(self, problem: DPProblem):
        self.problem, self.rows = problem, 0
        self.scratch: dict[int, _Scratch] = {}
        self.weights = problem.reward_params.weights(problem.lhv, battery=False, soc_deviation=False, overheat=True,
                                                     soc_band=True)

    def get(self, rows: int) -> StageBuffers:
        if rows > self.rows:
            n = max(rows, int(self.rows * 1.5))
            self.so, self.c, self.e, self.a = np.empty((n, N_STATE)), np.empty(n), np.empty(n), np.empty(n)
            self.no_heat = np.zeros(n)  # the heat cost of every row where heat has no price (read only)
            self.rows = n
        return self

    def block(self, part: int, rows: int) -> _Scratch:
        """Thread ``part``'s scratch of at least ``rows`` rows."""
        sc = self.scratch.get(part)
        if sc is None or sc.x.shape[0] < rows:
            sc = self.scratch[part] = _Scratch(self.problem, rows)
        return sc


def expand(problem: DPProblem, i: int, states: np.ndarray, cost: np.ndarray, batt_j: np.ndarray, u: np.ndarray,
           threads: int, buf: StageBuffers) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every state × every split ``u`` of stage ``i``: next states, cost-to-come, battery energy and the splits (views
    of ``buf``, valid until the next stage). Blocks of states (:data:`BLOCK_ROWS` rows) run on ``threads`` threads in
    turn (:func:`expand_kernel`)."""
    p, m = states.shape[0], u.size
    rows = p * m
    b = buf.get(rows)
    so, c, e, a = b.so[:rows], b.c[:rows], b.e[:rows], b.a[:rows]
    a.reshape(p, m)[:] = u
    v0, v1, g = (float(x[0]) for x in problem.stage_inputs(i, 1))
    core = problem.core
    states = np.ascontiguousarray(states, dtype=np.float64)
    cost = np.ascontiguousarray(cost, dtype=np.float64)
    batt_j = np.ascontiguousarray(batt_j, dtype=np.float64)
    per_block = max(1, BLOCK_ROWS // m)  # states per block
    parts = threads if rows >= MIN_THREAD_BATCH and p >= threads > 1 else 1

    def run(part: int) -> None:
        sc = buf.block(part, per_block * m)
        sc.v0[:], sc.v1[:], sc.g[:] = v0, v1, g  # the stage's speeds and grade: the same for every row
        expand_kernel(*core.params, core.dt_s, buf.weights, float(problem.soc_target), states, cost, batt_j, m, a,
                      sc.v0, sc.v1, sc.g, sc.cond, sc.before, sc.x, sc.out, so, c, e, part * per_block,
                      parts * per_block, per_block)

    if parts == 1:
        run(0)
    else:
        list(thread_pool(parts).map(run, range(parts)))
    return so, c, e, a
