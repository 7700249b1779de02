"""One stage of the thermal optimum's search (:mod:`.search`): every surviving state × every split, stepped by the
env's own :func:`~hev_thermal_env.physics.core.step_kernel` and priced by its
:func:`~hev_thermal_env.envs.reward.reward_row` in one compiled call per thread (:func:`expand`), then binned: a
candidate's bin is floor(state / width) per key column, packed into one 64-bit key; each bin keeps at most four
states (:func:`keep_best_per_bin`), and the states another dominates are dropped (:func:`non_dominated`).
"""

from __future__ import annotations

import numpy as np

from hev_thermal_env.envs.reward import reward_row
from hev_thermal_env.physics import core
from hev_thermal_env.physics.core import BATT_CHEM, N_OUT, N_STATE, SOC, step_kernel
from hev_thermal_env.physics.jit import MIN_THREAD_BATCH, jit, thread_pool

from .problem import DPProblem

#: Rows one thread steps and prices at a time, in scratch arrays reused block after block so that they stay in the
#: core's cache. Threads take the blocks in turn (block k to thread k mod threads), so a run of costly rows is shared.
BLOCK_ROWS = 4096


@jit
def expand_kernel(gl, dl, en, mo, th, ba, pt, dt, w, target, states, cost, batt_j, m, a, v0, v1, g, cond, before, x,
                  out, so, c, e, first, stride, per_block):
    """The blocks of states ``first``, ``first + stride``, ... (``per_block`` states each) of one stage; row r of a
    stage is state r // m with split r % m (m splits).

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


#: State columns the search bins on, in key order, and the bits each gets in the 64-bit key (63 in all): a
#: column's bin index must lie within ±2^(bits-1), which :func:`.search.check_key_range` enforces (SOC: ±2^20 bins, so
#: bins down to 10⁻⁶ of SOC; temperatures and heat index ±512 bins).
KEY_COLUMNS = (core.SOC, core.TEMP_C, core.WINDING_C, core.COOLANT_C, core.HEAT_X, core.CUTOFF, core.WINDING_TRIP)
KEY_BITS = (21, 10, 10, 10, 10, 1, 1)
_KEY_COLS = np.array(KEY_COLUMNS, dtype=np.int64)
_BITS = np.array(KEY_BITS, dtype=np.int64)
_THERMAL_BITS = _BITS[1:].copy()  # the key fields after SOC's: the thermal bins


@jit
def _slot(key, mask):
    """The first table slot of ``key``: the splitmix64 finaliser, so every key bit reaches the bits ``mask`` keeps."""
    z = np.uint64(key)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return np.int64((z ^ (z >> np.uint64(31))) & np.uint64(mask))


@jit
def _push(key, q, bits):
    """``key`` with the bin index ``q`` appended in a field of ``bits`` bits (offset to non-negative, clamped to the
    field; :func:`.search.check_key_range` keeps the grid's indices inside it)."""
    q = min(max(q + (1 << (bits - 1)), 0), (1 << bits) - 1)
    return (key << bits) | q


@jit
def _group_stop(soc_bin, order, start):
    """The end of the run of rows in ``order`` from ``start`` that share one SOC bin."""
    stop = start
    while stop < order.shape[0] and soc_bin[order[stop]] == soc_bin[order[start]]:
        stop += 1
    return stop


@jit
def _fill_bins(states, inside, cost, batt_j, price, price2, price3, heat_g, key_cols, widths, bits, part, n_parts, cap,
               table_key, cheap, cool, second, priced):
    """One pass of :func:`keep_best_per_bin` with a table of ``cap`` slots over the rows whose first key column's bin
    is ``part`` modulo ``n_parts``; returns the number of bins, or -1 when the table would be more than half full (the
    caller retries with a larger one)."""
    mask = cap - 1
    table_key[:cap] = -1
    used = 0
    for b in range(states.shape[0]):
        if not inside[b] or int(np.floor(states[b, key_cols[0]] / widths[0])) % n_parts != part:
            continue
        key = 0
        for d in range(key_cols.shape[0]):
            key = _push(key, int(np.floor(states[b, key_cols[d]] / widths[d])), bits[d])
        h = _slot(key, mask)
        while True:
            k = table_key[h]
            if k == -1:
                used += 1
                if 2 * used > cap:
                    return -1
                table_key[h] = key
                cheap[h] = cool[h] = second[h] = priced[h] = b
                break
            if k == key:
                if cost[b] + price * batt_j[b] < cost[cheap[h]] + price * batt_j[cheap[h]]:
                    cheap[h] = b
                if price3 > 0.0:  # the slot holds the cheapest at a third battery price instead of the coolest
                    if cost[b] + price3 * batt_j[b] < cost[cool[h]] + price3 * batt_j[cool[h]]:
                        cool[h] = b
                elif hotness(states, b) < hotness(states, cool[h]):
                    cool[h] = b
                if cost[b] + price2 * batt_j[b] < cost[second[h]] + price2 * batt_j[second[h]]:
                    second[h] = b
                p = priced[h]
                if cost[b] + price * batt_j[b] + heat_g[b] < cost[p] + price * batt_j[p] + heat_g[p]:
                    priced[h] = b
                break
            h = (h + 1) & mask
    return used


@jit
def hotness(states, b):
    """One number for "cooler" within a bin: motor (stator/housing) + winding + half the coolant temperature (K), plus
    20 K per unit heat index and 100 K for each protection that has stopped the motor (row ``b`` of ``states``)."""
    return (states[b, core.TEMP_C] + states[b, core.WINDING_C] + 0.5 * states[b, core.COOLANT_C]
            + 20.0 * states[b, core.HEAT_X] + 100.0 * (states[b, core.CUTOFF] + states[b, core.WINDING_TRIP]))


@jit
def keep_best_per_bin(states, inside, cost, batt_j, price, price2, price3, heat_g, key_cols, widths, bits, part,
                      n_parts, cap_hint, out_idx, keep_cool):
    """Of every bin, the cheapest row at battery price ``price`` (compared: ``cost + price · batt_j``, g), the
    cheapest at ``price2``, the coolest (:func:`hotness`; only with ``keep_cool``: where heat cannot bind the
    heat-priced one stands for it) and the cheapest at ``price`` with its heat priced (``heat_g``, g per row); writes
    their indices to ``out_idx`` (a row once) and returns how many. With ``price3`` > 0 the coolest's slot holds the
    cheapest at battery price ``price3`` instead (kept whatever ``keep_cool``). Why these four: docs/strategies.md.

    Skips rows with ``inside`` False and rows whose SOC bin is not ``part`` modulo ``n_parts`` (parts run on separate
    threads). An open-addressing hash table, sized from ``cap_hint`` (the expected number of bins) and grown when it
    fills, finds a row's bin in O(1).
    """
    cap = 1024
    while cap < 4 * cap_hint:
        cap *= 2
    while True:
        table_key = np.empty(cap, dtype=np.int64)
        cheap = np.empty(cap, dtype=np.int64)
        cool = np.empty(cap, dtype=np.int64)
        second = np.empty(cap, dtype=np.int64)
        priced = np.empty(cap, dtype=np.int64)
        used = _fill_bins(states, inside, cost, batt_j, price, price2, price3, heat_g, key_cols, widths, bits, part,
                          n_parts, cap, table_key, cheap, cool, second, priced)
        if used >= 0:
            break
        cap *= 4
    j = 0
    for h in range(cap):
        if table_key[h] != -1:
            out_idx[j] = cheap[h]
            j += 1
            if cool[h] != cheap[h] and (keep_cool or price3 > 0.0):
                out_idx[j] = cool[h]
                j += 1
            if second[h] != cheap[h] and second[h] != cool[h]:
                out_idx[j] = second[h]
                j += 1
            if priced[h] != cheap[h] and priced[h] != cool[h] and priced[h] != second[h]:
                out_idx[j] = priced[h]
                j += 1
    return j


@jit
def pareto_per_soc_bin(soc_bin, q, order, keep):
    """Drop every state dominated within its SOC bin; returns how many survive (written to ``keep``).

    ``order`` sorts the rows by (SOC bin, adjusted cost). A row is dominated when a cheaper row of its SOC bin lies in a
    cooler thermal bin: no hotter in any of ``q``'s columns (bin indices: motor, winding, coolant, heat index, cutoff,
    winding trip) and cooler in one; rows of the same bin do not dominate each other. Cooler is never worse in this
    physics (less derate, lower copper loss, stronger magnets, no protection tripped).
    """
    n = order.shape[0]
    d_count = q.shape[1]
    kept = 0
    start = 0
    while start < n:
        stop = _group_stop(soc_bin, order, start)
        first = kept
        for t in range(start, stop):
            b = order[t]
            dominated = False
            for j in range(first, kept):
                k = keep[j]
                worse = True
                strict = False
                for d in range(d_count):
                    if q[k, d] > q[b, d]:
                        worse = False
                        break
                    if q[k, d] < q[b, d]:
                        strict = True
                if worse and strict:
                    dominated = True
                    break
            if not dominated:
                keep[kept] = b
                kept += 1
        start = stop
    return kept


@jit
def dominated_by_fuller(soc_bin, q, value, order, out):
    """Mark (``out``) every row that a row of a higher SOC bin and the same thermal bins (``q``: motor, winding,
    coolant, heat index, cutoff, winding trip) beats or ties on ``value``; returns how many are marked.

    Used where heat cannot bind (:func:`~.search.heat_stays_cheap`; why: docs/strategies.md), with ``value`` the
    cost-to-come plus the heat at its price. ``order`` sorts the rows by SOC bin descending. Rows are grouped by SOC
    bin and a group is compared only with the fuller groups before it, so the representatives of one bin
    (:func:`keep_best_per_bin`) all stay. The lowest value of every thermal bin's fuller rows is kept in an
    open-addressing table keyed by the bins.
    """
    n = order.shape[0]
    d_count = q.shape[1]
    cap = 64
    while cap < 4 * n:
        cap *= 2
    mask = cap - 1
    table_key = np.full(cap, -1, dtype=np.int64)
    table_min = np.empty(cap)
    marked = 0
    start = 0
    while start < n:
        stop = _group_stop(soc_bin, order, start)
        for phase in range(2):  # 0: look up the fuller groups' lowest values; 1: add this group's
            for t in range(start, stop):
                b = order[t]
                key = 0
                for d in range(d_count):
                    key = _push(key, q[b, d], _THERMAL_BITS[d])
                h = _slot(key, mask)
                while table_key[h] != -1 and table_key[h] != key:
                    h = (h + 1) & mask
                if phase == 0:
                    out[b] = table_key[h] == key and table_min[h] <= value[b]
                    if out[b]:
                        marked += 1
                elif table_key[h] == -1:
                    table_key[h] = key
                    table_min[h] = value[b]
                elif value[b] < table_min[h]:
                    table_min[h] = value[b]
        start = stop
    return marked


def non_dominated(states: np.ndarray, adj: np.ndarray, widths: np.ndarray, rows: np.ndarray,
                  fuller_value: np.ndarray | None = None) -> np.ndarray:
    """``rows`` without the states dominated within their SOC bin (:func:`pareto_per_soc_bin`, by ``adj``) and, with
    ``fuller_value`` (per row), without those a fuller state of their thermal bins beats on it
    (:func:`dominated_by_fuller`)."""
    bins = np.floor(states[:, list(KEY_COLUMNS)] / widths).astype(np.int64)
    order = np.lexsort((adj, bins[:, 0]))
    out = np.empty(rows.size, dtype=np.int64)
    k = pareto_per_soc_bin(bins[:, 0].copy(), np.ascontiguousarray(bins[:, 1:]), order, out)
    kept = out[:k]
    if fuller_value is None or k < 2:
        return rows[kept]
    bins = bins[kept]
    dropped = np.zeros(k, dtype=np.bool_)
    dominated_by_fuller(bins[:, 0].copy(), np.ascontiguousarray(bins[:, 1:]),
                        np.ascontiguousarray(fuller_value[kept]), np.argsort(-bins[:, 0], kind="stable"), dropped)
    return rows[kept[~dropped]]


def survivors(so: np.ndarray, inside: np.ndarray, c: np.ndarray, e: np.ndarray, price: float, price2: float,
              heat_g: np.ndarray, widths: np.ndarray, hint: int, threads: int, keep_cool: bool = True,
              price3: float = 0.0) -> np.ndarray:
    """:func:`keep_best_per_bin` over all rows, the SOC bins split into ``threads`` parts run in parallel."""
    n_parts = threads if so.shape[0] >= MIN_THREAD_BATCH and threads > 1 else 1

    def run(part: int) -> np.ndarray:
        buf = np.empty(so.shape[0], dtype=np.int64)
        k = keep_best_per_bin(so, inside, c, e, price, price2, price3, heat_g, _KEY_COLS, widths, _BITS, part,
                              n_parts, max(hint // n_parts, 1024), buf, keep_cool)
        return buf[:k]

    if n_parts == 1:
        return run(0)
    return np.concatenate(list(thread_pool(n_parts).map(run, range(n_parts))))
