"""The thermal optimum's search: forward dynamic programming over exact physics states (cost-to-come).

Why forward, and why exact states. The thermal state that matters is five numbers (SOC, winding,
housing and coolant temperatures, heat-index integrator, plus the cutoff flag with its 60-70 °C
hysteresis). A backward DP must interpolate its cost-to-go between grid points in every one of
them, and with six dimensions either the grid is too coarse to be an optimum or the solve takes
hours. This search runs the other way:

1. Start from the run's exact initial state. At each stage every surviving state is expanded by
   every split u of a uniform grid (one split where the shaft demand is not positive: the action
   has no effect), all in ONE batched call of the physics core
   (:meth:`~hev_thermal_env.physics.PhysicsCore.step`), so every candidate is an exact state of
   the environment's physics and every cost is the environment's reward.
2. The candidates are binned on a grid over (SOC, winding, housing, coolant temperature, heat
   index, cutoff flag); in each occupied bin at most three states survive: the lowest
   cost-to-come *including the battery energy at the reward's battery price* (two states a
   fraction of a bin apart in SOC compared on equal charge, to first order), the lowest with the
   battery at 0.8 of that price, and the coolest (:func:`keep_best_per_bin`). Then, within each
   SOC bin, a state is dropped when a cheaper one lies in a cooler thermal bin
   (:func:`pareto_per_soc_bin`): cooler is never worse in this physics.
3. States that cannot reach the final-SOC window any more (outside the backward SOC envelope,
   :mod:`.dp_corridor`) are dropped.

Nothing is interpolated: a surviving path is a real action sequence whose planned cost *is* its
realised cost (replayed in the env, the same kernel gives the same numbers). What the grid costs
is pruning: two states in one bin are treated as interchangeable, so the search can drop a state
that is cheaper later. That error shrinks with the bin widths; ``benchmarks/optimum.py`` measures
it by halving every bin and doubling the split grid, and against a very fine search on short cycles.

The frontier comes from the same pass: at the last stage the survivors give the lowest cost for
every final SOC, F(s) = min{cost of a surviving path whose final SOC ≥ s}, monotone by
construction (ending with more charge than asked is allowed). Cost = the yardstick cost: fuel +
missed wheel energy at the miss price + the reward's overheat terms (battery and SOC-deviation
terms off): the frontier prices charge by SOC, not by a chosen battery price.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.door_arrays import MIN_THREAD_BATCH, thread_pool
from hev_thermal_env.physics.jit import jit

from .common import default_threads
from .dp_corridor import backward_envelope
from .dp_grid import DPProblem
from .optimum_stage import StageBuffers, expand

#: State columns the search bins on, in key order, and the bits each gets in the 64-bit key (63 in all): a
#: column's bin index must lie within ±2^(bits-1), which :func:`check_key_range` enforces (SOC: ±2^20 bins, so
#: bins down to 10⁻⁶ of SOC; temperatures ±512 bins; heat index ±1,024 bins).
KEY_COLUMNS = (C.SOC, C.TEMP_C, C.HOUSING_C, C.COOLANT_C, C.HEAT_X, C.CUTOFF)
KEY_BITS = (21, 10, 10, 10, 11, 1)


@dataclass(frozen=True)
class SearchGrid:
    """Bin widths of the search (state units) and the split grid; ``scaled(f)`` divides every width by f.

    ``second_price``: each bin also keeps its cheapest state with the battery priced at this fraction
    of the reward's price (see :func:`keep_best_per_bin`); ``dominance``: drop states dominated
    within their SOC bin (:func:`pareto_per_soc_bin`).
    """

    soc: float = 1.5e-4
    winding_k: float = 4.0
    housing_k: float = 2.0
    coolant_k: float = 4.0
    heat_index: float = 0.1
    n_u: int = 31
    dominance: bool = True
    second_price: float = 0.8

    def widths(self) -> np.ndarray:
        return np.array([self.soc, self.winding_k, self.housing_k, self.coolant_k, self.heat_index, 1.0])

    def scaled(self, factor: float) -> SearchGrid:
        """Every bin ``factor`` times narrower, ``factor`` times as many split intervals (an even number: u = 0
        stays)."""
        return SearchGrid(self.soc / factor, self.winding_k / factor, self.housing_k / factor,
                          self.coolant_k / factor, self.heat_index / factor,
                          2 * int(round((self.n_u - 1) * factor / 2)) + 1, self.dominance, self.second_price)

    def describe(self) -> str:
        return (f"forward DP over exact states, bins ΔSOC {self.soc:g}, winding {self.winding_k:g} K, housing "
                f"{self.housing_k:g} K, coolant {self.coolant_k:g} K, heat index {self.heat_index:g}, "
                f"{self.n_u} splits")


@dataclass
class SearchResult:
    """The survivors of the last stage and how to get to each of them."""

    final_state: np.ndarray  # [M, N_STATE]
    final_cost_g: np.ndarray  # [M] yardstick cost
    final_battery_j: np.ndarray  # [M] net battery chemical energy
    parents: list[np.ndarray]  # per stage: index of each survivor's parent in the previous stage's survivors
    actions: list[np.ndarray]  # per stage: the split each survivor took
    grid: SearchGrid
    solve_s: float
    n_evals: int
    max_states: int
    info: dict = field(default_factory=dict)

    def path(self, j: int) -> np.ndarray:
        """The action sequence that ends in final survivor ``j``."""
        n = len(self.actions)
        u = np.empty(n)
        for i in range(n - 1, -1, -1):
            u[i] = self.actions[i][j]
            j = self.parents[i][j]
        return u

    def frontier(self) -> tuple[np.ndarray, np.ndarray]:
        """The frontier's breakpoints (final SOC ascending, cost non-decreasing): :func:`frontier_points` of the
        final survivors."""
        return frontier_points(self.final_state[:, C.SOC], self.final_cost_g)


def frontier_points(soc: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The final states that no other beats with both more final charge and a lower cost, by SOC ascending.

    F(s) = the lowest cost of a path ending at SOC >= s is the cost of the first breakpoint at or above s;
    linear interpolation between breakpoints never exceeds it.
    """
    order = np.argsort(soc, kind="stable")
    s, c = soc[order], cost[order]
    after = np.r_[np.minimum.accumulate(c[::-1])[::-1][1:], np.inf]  # lowest cost strictly above in order
    keep = c < after
    return s[keep], c[keep]


@jit
def _fill_bins(states, inside, cost, batt_j, price, price2, key_cols, widths, bits, part, n_parts, cap, table_key,
               cheap, cool, second):
    """One pass of :func:`keep_best_per_bin` with a table of ``cap`` slots over the rows whose first key column's bin
    is ``part`` modulo ``n_parts``; returns the number of bins, or -1 when the table would be more than half full
    (the caller retries with a larger one)."""
    mask = cap - 1
    table_key[:cap] = -1
    used = 0
    for b in range(states.shape[0]):
        if not inside[b]:
            continue
        if int(np.floor(states[b, key_cols[0]] / widths[0])) % n_parts != part:
            continue
        key = 0
        for d in range(key_cols.shape[0]):
            q = int(np.floor(states[b, key_cols[d]] / widths[d])) + (1 << (bits[d] - 1))
            q = min(max(q, 0), (1 << bits[d]) - 1)
            key = (key << bits[d]) | q
        z = np.uint64(key)  # splitmix64 finaliser: every key bit reaches the low bits the mask keeps
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        h = np.int64((z ^ (z >> np.uint64(31))) & np.uint64(mask))
        while True:
            k = table_key[h]
            if k == -1:
                used += 1
                if 2 * used > cap:
                    return -1
                table_key[h] = key
                cheap[h] = b
                cool[h] = b
                second[h] = b
                break
            if k == key:
                if cost[b] + price * batt_j[b] < cost[cheap[h]] + price * batt_j[cheap[h]]:
                    cheap[h] = b
                if hotness(states, b) < hotness(states, cool[h]):
                    cool[h] = b
                if cost[b] + price2 * batt_j[b] < cost[second[h]] + price2 * batt_j[second[h]]:
                    second[h] = b
                break
            h = (h + 1) & mask
    return used


@jit
def hotness(states, b):
    """One number for "cooler" within a bin: winding + housing + half the coolant temperature (K), plus 20 K per
    unit heat index and 100 K when cut off (row ``b`` of ``states``)."""
    return (states[b, C.TEMP_C] + states[b, C.HOUSING_C] + 0.5 * states[b, C.COOLANT_C] + 20.0 * states[b, C.HEAT_X]
            + 100.0 * states[b, C.CUTOFF])


@jit
def keep_best_per_bin(states, inside, cost, batt_j, price, price2, key_cols, widths, bits, part, n_parts, cap_hint,
                      out_idx):
    """Of every bin, the cheapest row at battery price ``price``, the cheapest at ``price2`` and the coolest.

    Rows with ``inside`` False are skipped, and so are rows whose SOC bin is not ``part`` modulo
    ``n_parts`` (bins of different SOC are disjoint, so parts can run on separate threads). The cost
    compared is ``cost + price · batt_j`` (g; the
    battery's net chemical energy ``batt_j`` priced), coolness is :func:`hotness`. Writes the rows'
    indices to ``out_idx`` (once where they are the same row) and returns how many.
    One representative per bin drifts: within a bin the state that is cheaper now is usually the
    hotter one (it used the motor more) or the emptier one, and choosing it at every stage walks
    the search a fraction of a bin hotter (or emptier) each step. ``price`` is the reward's battery
    price and ``price2`` lower; when the true value of charge on this cycle lies between the two,
    the better lineage survives. On 200 s of Beijing in the ``hot`` scenario one representative at
    ΔSOC 2.5·10⁻⁴ left ECMS 0.6 % below the frontier; three at 1.5·10⁻⁴, 0.06 %. The bin of a row
    is floor(state / width) per key column, packed into one 64-bit key; an open-addressing hash
    table (sized from ``cap_hint``, the expected number of bins, and grown when it fills) finds the
    bin in O(1).
    """
    cap = 1024
    while cap < 4 * cap_hint:
        cap *= 2
    while True:
        table_key = np.empty(cap, dtype=np.int64)
        cheap = np.empty(cap, dtype=np.int64)
        cool = np.empty(cap, dtype=np.int64)
        second = np.empty(cap, dtype=np.int64)
        used = _fill_bins(states, inside, cost, batt_j, price, price2, key_cols, widths, bits, part, n_parts, cap,
                          table_key, cheap, cool, second)
        if used >= 0:
            break
        cap *= 4
    j = 0
    for h in range(cap):
        if table_key[h] != -1:
            out_idx[j] = cheap[h]
            j += 1
            if cool[h] != cheap[h]:
                out_idx[j] = cool[h]
                j += 1
            if second[h] != cheap[h] and second[h] != cool[h]:
                out_idx[j] = second[h]
                j += 1
    return j


@jit
def pareto_per_soc_bin(soc_bin, q, order, keep):
    """Drop every state dominated within its SOC bin; returns how many survive (written to ``keep``).

    ``order`` sorts the rows by (SOC bin, adjusted cost). A row is dominated when a cheaper row of
    the same SOC bin lies in a cooler thermal bin: no hotter bin in any thermal coordinate and a
    cooler one in at least one (``q`` [M, D], bin indices: winding, housing, coolant, heat index,
    cutoff). Rows of the same bin (the bin's cheapest and its coolest) do not dominate each other.
    Cooler is never worse in this physics (less derate,
    lower copper loss, stronger magnets, no cutoff), so the dominated state cannot lead to a
    cheaper path.
    """
    n = order.shape[0]
    d_count = q.shape[1]
    kept = 0
    start = 0
    while start < n:
        stop = start
        while stop < n and soc_bin[order[stop]] == soc_bin[order[start]]:
            stop += 1
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


def soc_window(problem: DPProblem, lo_final: float, hi_final: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Per stage, the SOC range from which the final window [lo_final, hi_final] is still reachable.

    Computed with the motor at full capability (no heat index, not cut off), which can only widen
    the range, and widened by ``margin``.
    """
    ref = problem.state0.copy()
    ref[C.HEAT_X] = min(ref[C.HEAT_X], ref[C.HEAT_X_MIN])
    ref[C.CUTOFF] = 0.0
    held = np.repeat(ref[None, :], problem.n_stages + 1, axis=0)
    lo, hi = backward_envelope(problem, held, (lo_final, hi_final))
    return lo - margin, hi + margin


def _non_dominated(states: np.ndarray, adj: np.ndarray, widths: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``rows`` without the states dominated within their SOC bin (:func:`pareto_per_soc_bin`)."""
    bins = np.floor(states[:, list(KEY_COLUMNS)] / widths).astype(np.int64)
    order = np.lexsort((adj, bins[:, 0]))
    out = np.empty(rows.size, dtype=np.int64)
    k = pareto_per_soc_bin(bins[:, 0].copy(), np.ascontiguousarray(bins[:, 1:]), order, out)
    return rows[out[:k]]


def check_key_range(grid: SearchGrid, temp_hi_c: float = 250.0) -> None:
    """Raise when a bin index could leave its key field (different states would then share a bin): SOC up to 1,
    temperatures up to ``temp_hi_c``, heat index up to 1."""
    fields = {"soc": (1.0, grid.soc, KEY_BITS[0]), "winding_k": (temp_hi_c, grid.winding_k, KEY_BITS[1]),
              "housing_k": (temp_hi_c, grid.housing_k, KEY_BITS[2]),
              "coolant_k": (temp_hi_c, grid.coolant_k, KEY_BITS[3]), "heat_index": (1.0, grid.heat_index, KEY_BITS[4])}
    for name, (top, width, bits) in fields.items():
        if top / width >= 2 ** (bits - 1) - 1:
            raise ValueError(f"dp_thermal: the {name} bin {width:g} is too narrow for the search's bin keys (at most "
                             f"{2 ** (bits - 1) - 1} bins up to {top:g}); use a wider bin or a smaller grid_scale")


def _survivors(so, inside, c, e, price, price2, key_cols, widths, bits, hint, threads) -> np.ndarray:
    """:func:`keep_best_per_bin` over all rows, the SOC bins split into ``threads`` parts run in parallel."""
    n_parts = threads if so.shape[0] >= MIN_THREAD_BATCH and threads > 1 else 1

    def run(part: int) -> np.ndarray:
        buf = np.empty(so.shape[0], dtype=np.int64)
        k = keep_best_per_bin(so, inside, c, e, price, price2, key_cols, widths, bits, part, n_parts,
                              max(hint // n_parts, 1024), buf)
        return buf[:k]

    if n_parts == 1:
        return run(0)
    return np.concatenate(list(thread_pool(n_parts).map(run, range(n_parts))))


def search(problem: DPProblem, grid: SearchGrid, final_window: tuple[float, float], *, threads: int | None = None,
           progress=None, u_center: np.ndarray | None = None,
           local_halfwidth: float = 0.05, n_local: int = 21, global_stride: int = 1,
           tube: tuple[np.ndarray, np.ndarray] | None = None) -> SearchResult:
    """The forward pass over the cycle (see the module docstring); ``final_window`` bounds the final SOCs kept.

    ``u_center`` (one split per stage, e.g. a previous pass's path, or several such paths [k, n])
    adds ``n_local`` splits within ± ``local_halfwidth`` of each to every ``global_stride``-th split
    of the uniform grid at every stage: a refining pass.
    ``tube`` (SOC bounds per stage 0..n) also drops the states outside it (at a stage where none is
    inside, the tube is ignored). ``progress(stage, n_stages, n_states)`` is called after every stage.
    """
    t0 = time.perf_counter()
    n = problem.n_stages
    if n < 1:
        raise ValueError("dp_thermal: the cycle has no step left to plan")
    threads = default_threads() if threads is None else threads
    lo_win, hi_win = soc_window(problem, final_window[0], final_window[1], margin=2.0 * grid.soc)
    check_key_range(grid)
    u_grid = np.linspace(-1.0, 1.0, grid.n_u).astype(np.float32).astype(np.float64)  # replayable exactly
    u_idle = np.zeros(1)
    active = problem.demand_positive()
    batt_g_per_j = problem.reward_params.prices.battery_g_per_j(problem.lhv) * problem.reward_params.soc_energy_weight
    key_cols = np.array(KEY_COLUMNS, dtype=np.int64)
    widths, bits = grid.widths(), np.array(KEY_BITS, dtype=np.int64)
    states = problem.state0[None, :].copy()
    cost = np.zeros(1)
    batt_j = np.zeros(1)
    parents: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    n_evals = 0
    max_states = 1
    local = np.linspace(-local_halfwidth, local_halfwidth, n_local)
    centers = None if u_center is None else np.atleast_2d(np.asarray(u_center, dtype=np.float64))
    buffers = StageBuffers(problem)
    for i in range(n):
        u = u_grid if active[i] else u_idle
        if u_center is not None and active[i]:
            near = np.clip((centers[:, i, None] + local).ravel(), -1.0, 1.0)
            u = np.unique(np.r_[u_grid[::global_stride], u_grid[-1], near].astype(np.float32)).astype(np.float64)
        so, c, e, a = expand(problem, i, states, cost, batt_j, u, threads, buffers)
        n_evals += so.shape[0]
        soc = so[:, C.SOC]
        inside = (soc >= lo_win[i + 1]) & (soc <= hi_win[i + 1])
        if tube is not None:
            in_tube = inside & (soc >= tube[0][i + 1]) & (soc <= tube[1][i + 1])
            if np.any(in_tube):
                inside = in_tube
        if not np.any(inside):
            inside[np.argmin(np.minimum(np.abs(soc - lo_win[i + 1]), np.abs(soc - hi_win[i + 1])))] = True
        keep = _survivors(so, inside, c, e, batt_g_per_j, grid.second_price * batt_g_per_j, key_cols, widths, bits,
                          states.shape[0], threads)
        if grid.dominance and keep.size > 1:
            keep = _non_dominated(so[keep], c[keep] + batt_g_per_j * e[keep], widths, keep)
        keep = np.sort(keep)
        states, cost, batt_j = so[keep], c[keep], e[keep]
        parents.append((keep // u.size).astype(np.int32))
        actions.append(a[keep].astype(np.float32) if active[i] else np.zeros(keep.size, dtype=np.float32))
        max_states = max(max_states, keep.size)
        if progress is not None:
            progress(i + 1, n, keep.size)
    return SearchResult(final_state=states, final_cost_g=cost, final_battery_j=batt_j, parents=parents,
                        actions=actions, grid=grid, solve_s=time.perf_counter() - t0, n_evals=n_evals,
                        max_states=max_states, info={"threads": threads, "final_soc_window": list(final_window),
                                              "tube": tube is not None})
