"""The thermal optimum's search: forward dynamic programming over exact physics states (cost-to-come).

Why forward, the bins, the heat prices and the passes: docs/strategies.md. Each stage (:mod:`.stage`) expands every
surviving state by every split the stage offers, keeps a few per bin and drops those that can no longer reach the
final-SOC window (the backward SOC envelope of :mod:`.soc_dp`). Nothing is interpolated: a surviving path's planned
cost is its realised cost. The last stage's survivors give the frontier (:func:`frontier_points`), at the yardstick
cost (fuel, missed wheel energy at the miss price, the reward's overheat terms; no battery price).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from hev_thermal_env.envs.reward import stage_cost_g
from hev_thermal_env.physics import core

from .problem import BRAKING, IDLE, TRACTION, DPProblem, default_threads, split_grid, stage_splits
from .soc_dp import backward_envelope
from .stage import KEY_BITS, KEY_COLUMNS, StageBuffers, expand, non_dominated, survivors

#: The priced temperatures, in the order of the price columns.
PRICED = (core.TEMP_C, core.WINDING_C, core.COOLANT_C)
#: Stages between two measured prices; the temperature step of the finite difference (K).
EVERY, DELTA_K = 10, 1.0
#: Where each priced temperature (:data:`PRICED`) sits in :meth:`SearchGrid.widths`.
_PRICED_KEY = tuple(KEY_COLUMNS.index(col) for col in PRICED)

#: Each bin also keeps its cheapest state with the battery priced at this fraction of the reward's price
#: (:func:`~.stage.keep_best_per_bin`).
SECOND_PRICE = 0.8
#: Where heat stays cheap over the whole cycle (the coarse pass is skipped, :mod:`.thermal_optimum`), the slot of a
#: bin's coolest state holds its cheapest with the battery priced at this fraction of the reward's price.
THIRD_PRICE = 1.2
#: A refining pass: every ``REFINE_STRIDE``-th split of the uniform grid, u = 0, and ``N_LOCAL`` splits within
#: ± ``LOCAL_HALFWIDTH`` of each earlier path.
REFINE_STRIDE, N_LOCAL, LOCAL_HALFWIDTH = 2, 11, 0.05


@dataclass(frozen=True)
class SearchGrid:
    """Bin widths of the search (state units: ``housing_k`` the motor temperature, the stator/housing node;
    ``winding_k`` the winding's), the split grid, and how far the temperature bins widen where heat is cheap
    (:meth:`stage_widths`).

    The winding's bin holds less heat than the housing's (8 K × 3.3 kJ/K against 2 K × 43 kJ/K): the winding matters
    through the heat it passes to the housing and through its own trip, far above where the housing cuts the motor off;
    at 4 K its bins kept 1.3 times the vehicle-steps (the first 600 s of Beijing, paper).
    """

    soc: float = 1.5e-4
    winding_k: float = 8.0
    housing_k: float = 2.0
    coolant_k: float = 4.0
    heat_index: float = 0.1
    n_u: int = 31
    heat_bin_g: float = 1.0
    heat_bin_max: float = 8.0

    def __post_init__(self) -> None:
        if not (self.heat_bin_max >= 1.0 and self.heat_bin_g > 0.0):
            raise ValueError(f"SearchGrid: need heat_bin_max >= 1 and heat_bin_g > 0 (a bin never narrower than its "
                             f"width), got {self.heat_bin_max}, {self.heat_bin_g}")

    def widths(self) -> np.ndarray:
        """The widths in the order of :data:`~.stage.KEY_COLUMNS` (the two protection flags: 1)."""
        return np.array([self.soc, self.housing_k, self.winding_k, self.coolant_k, self.heat_index, 1.0, 1.0])

    def scaled(self, factor: float) -> SearchGrid:
        """Every bin ``factor`` times narrower, ``factor`` times as many split intervals (even: u = 0 stays)."""
        return SearchGrid(self.soc / factor, self.winding_k / factor, self.housing_k / factor, self.coolant_k / factor,
                          self.heat_index / factor, 2 * int(round((self.n_u - 1) * factor / 2)) + 1,
                          self.heat_bin_g / factor, self.heat_bin_max)

    def stage_widths(self, heat_price: np.ndarray | None) -> np.ndarray:
        """The bin widths of a stage whose temperatures :data:`PRICED` cost ``heat_price`` g/K: each priced
        temperature's bin holds ``heat_bin_g`` of heat, within [1, ``heat_bin_max``] times its width here (a price of
        0: the widest; no prices, or one that is not a finite number: the widths here)."""
        w = self.widths()
        if heat_price is None:
            return w
        for col, mu in zip(_PRICED_KEY, heat_price):
            if not np.isfinite(mu):
                continue
            wide = self.heat_bin_g / mu if mu > 0.0 else np.inf
            w[col] = min(max(wide, w[col]), self.heat_bin_max * w[col])
        return w

    def describe(self) -> str:
        return (f"forward DP over exact states, bins ΔSOC {self.soc:g}, motor (stator/housing) {self.housing_k:g} K, "
                f"winding {self.winding_k:g} K, coolant {self.coolant_k:g} K (each up to {self.heat_bin_max:g}× as "
                f"wide where that holds at most {self.heat_bin_g:g} g of heat), heat index {self.heat_index:g}, "
                f"{self.n_u} splits (their shares in [0, 1] while braking)")


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


def frontier_points(soc: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The final states that no other beats with both more final charge and a lower cost, by SOC ascending.

    F(s) = the lowest cost of a path ending at SOC >= s is the cost of the first breakpoint at or above s; linear
    interpolation between breakpoints never exceeds it.
    """
    order = np.argsort(soc, kind="stable")
    s, c = soc[order], cost[order]
    after = np.r_[np.minimum.accumulate(c[::-1])[::-1][1:], np.inf]  # lowest cost strictly above in order
    keep = c < after
    return s[keep], c[keep]


def soc_window(problem: DPProblem, lo_final: float, hi_final: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Per stage, the SOC range from which the final window [lo_final, hi_final] is still reachable, widened by
    ``margin``; with the motor at full capability (no heat index, neither protection tripped), which can only widen it.
    """
    ref = problem.state0.copy()
    ref[core.HEAT_X] = min(ref[core.HEAT_X], ref[core.HEAT_X_MIN])
    ref[core.CUTOFF] = ref[core.WINDING_TRIP] = 0.0
    lo, hi = backward_envelope(problem, ref, (lo_final, hi_final))
    return lo - margin, hi + margin


def heat_stays_cheap(grid: SearchGrid, heat_price: np.ndarray | None, n: int) -> np.ndarray:
    """Per stage 0..n: True where heat cannot bind from then to the end: a bin of each priced temperature at the grid's
    own width holds at most ``heat_bin_g`` of heat at every later stage's price (``paper`` conditions: HWFET 0.3 g,
    Beijing 0.07 g; ``hot``: about 100 g). There a bin needs no coolest representative and a fuller state of the same
    bins that costs no more with its heat priced replaces a state (:func:`~.stage.dominated_by_fuller`). False at the
    last stage (the final-SOC band needs its states) and everywhere without prices or with a price that is not a
    finite number."""
    out = np.zeros(n + 1, dtype=bool)
    if heat_price is None:
        return out
    worth = np.max(heat_price * grid.widths()[list(_PRICED_KEY)], axis=1)  # g of heat in a bin, per stage
    out[:] = np.maximum.accumulate(worth[::-1])[::-1] <= grid.heat_bin_g  # a NaN spreads to every earlier stage
    out[n] = False
    return out


def check_key_range(grid: SearchGrid, temp_hi_c: float = 250.0) -> None:
    """Raise when a bin index could leave its key field (different states would then share a bin): SOC up to 1,
    temperatures up to ``temp_hi_c``, heat index up to 1."""
    tops = (1.0, temp_hi_c, temp_hi_c, temp_hi_c, 1.0)
    for name, top, width, bits in zip(("soc", "housing_k", "winding_k", "coolant_k", "heat_index"), tops,
                                      grid.widths(), KEY_BITS):
        if top / width >= 2 ** (bits - 1) - 1:
            raise ValueError(f"dp_thermal: the {name} bin {width:g} is too narrow for the search's bin keys (at most "
                             f"{2 ** (bits - 1) - 1} bins up to {top:g}); use a wider bin or a smaller grid_scale")


def _stage_splits(u_grid: np.ndarray, centers: np.ndarray | None, i: int, kind: int,
                  seeds: np.ndarray | None = None) -> np.ndarray:
    """The splits of stage ``i`` (of ``kind``, :func:`~.problem.stage_splits`): the uniform grid's, or a refining
    pass's around each of ``centers``, and each seed path's own split (float32 values: a path's splits are stored as
    float32 and replayed exactly)."""
    if kind == IDLE:
        return stage_splits(kind, u_grid)
    own = np.empty(0) if seeds is None else seeds[:, i]
    if centers is None:
        u = u_grid if own.size == 0 else np.unique(np.r_[u_grid, own])
        return stage_splits(kind, u)
    near = np.clip((centers[:, i, None] + np.linspace(-LOCAL_HALFWIDTH, LOCAL_HALFWIDTH, N_LOCAL)).ravel(), -1.0, 1.0)
    u = np.unique(np.r_[u_grid[::REFINE_STRIDE], u_grid[-1], 0.0, near, own].astype(np.float32)).astype(np.float64)
    return stage_splits(kind, u)


def seed_splits(problem: DPProblem, u: np.ndarray) -> np.ndarray:
    """A driven action sequence ``u`` [k, n] as the splits the search offers (:func:`~.problem.stage_splits`): the
    action in traction, its share (u > 0, else 0) while braking, 0 where the action has no effect; float32 values."""
    kinds = problem.stage_kinds()
    u = np.atleast_2d(np.asarray(u, dtype=np.float32).astype(np.float64))[:, :problem.n_stages]
    if u.shape[1] != problem.n_stages:
        raise ValueError(f"dp_thermal: a seed path has {u.shape[1]} actions for {problem.n_stages} stages")
    return np.where(kinds == TRACTION, u, np.where(kinds == BRAKING, np.maximum(u, 0.0), 0.0))


def _keep_seeds(keep: np.ndarray, seed_at: np.ndarray, seeds: np.ndarray, u: np.ndarray, i: int, soc: np.ndarray,
                window: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """``keep`` with each seed path's candidate of stage ``i`` added while it is within the SOC ``window`` (a tube
    aside), and where each seed now sits among the survivors (-1: it left the window)."""
    live = np.flatnonzero(seed_at >= 0)
    cand = seed_at[live] * u.size + np.searchsorted(u, seeds[live, i])
    held = (soc[cand] >= window[0]) & (soc[cand] <= window[1])
    keep = np.union1d(keep, cand[held])
    seed_at = np.full_like(seed_at, -1)
    seed_at[live[held]] = np.searchsorted(keep, cand[held])
    return keep, seed_at


def _inside(soc: np.ndarray, lo: float, hi: float, tube: tuple[np.ndarray, np.ndarray] | None, k: int) -> np.ndarray:
    """The candidates within the SOC window [lo, hi] (and the tube at stage ``k``, where any is in it); at least the
    one nearest the window."""
    inside = (soc >= lo) & (soc <= hi)
    if tube is not None:
        in_tube = inside & (soc >= tube[0][k]) & (soc <= tube[1][k])
        if np.any(in_tube):
            inside = in_tube
    if not np.any(inside):
        inside[np.argmin(np.minimum(np.abs(soc - lo), np.abs(soc - hi)))] = True
    return inside


# numpy's one matrix product here (a stage's heat at its price) goes to OpenBLAS, whose threads then spin for a while
# after each call on the core the stage's own threads need: with them, two threads stepped HWFET slower than one
@threadpool_limits.wrap(limits=1, user_api="blas")
def search(problem: DPProblem, grid: SearchGrid, final_window: tuple[float, float], *, threads: int | None = None,
           progress=None, u_center: np.ndarray | None = None, tube: tuple[np.ndarray, np.ndarray] | None = None,
           heat_price: np.ndarray | None = None, third_price: bool = False,
           seeds: np.ndarray | None = None) -> SearchResult:
    """The forward pass over the cycle (see the module docstring); ``final_window`` bounds the final SOCs kept.

    ``u_center`` (paths [k, n], one split per stage) makes it a refining pass (:data:`REFINE_STRIDE`). ``tube`` (SOC
    bounds per stage 0..n) also drops the states outside it (at a stage where none is inside, the tube is ignored).
    ``heat_price`` (g/K of the temperatures :data:`PRICED` after each stage, [n + 1, 3]) gives each bin
    its heat-priced representative (:func:`~.stage.keep_best_per_bin`). ``third_price``: where heat stays cheap, a bin
    keeps its cheapest at :data:`THIRD_PRICE` in place of its coolest.
    ``seeds`` (paths [k, n] as :func:`seed_splits` gives them) are offered their own split at every stage and never
    dropped while within the SOC window: every seed that ends there is among the final survivors, so the frontier is
    no dearer than it at its final SOC.
    ``progress(stage, n_stages, n_states)`` is called after every stage.
    """
    t0 = time.perf_counter()
    n = problem.n_stages
    if n < 1:
        raise ValueError("dp_thermal: the cycle has no step left to plan")
    threads = default_threads() if threads is None else threads
    lo_win, hi_win = soc_window(problem, final_window[0], final_window[1], margin=2.0 * grid.soc)
    check_key_range(grid)
    u_grid = split_grid(grid.n_u).astype(np.float32).astype(np.float64)  # replayable exactly
    centers = None if u_center is None else np.atleast_2d(np.asarray(u_center, dtype=np.float64))
    kinds = problem.stage_kinds()
    batt_g_per_j = problem.reward_params.prices.battery_g_per_j(problem.lhv) * problem.reward_params.soc_energy_weight
    states, cost, batt_j = problem.state0[None, :].copy(), np.zeros(1), np.zeros(1)
    parents: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    n_evals, max_states = 0, 1
    buffers = StageBuffers(problem)
    cheap_heat = heat_stays_cheap(grid, heat_price, n)
    seed_at = np.zeros(0 if seeds is None else len(seeds), dtype=np.int64)
    for i in range(n):
        u = _stage_splits(u_grid, centers, i, int(kinds[i]), seeds)
        so, c, e, a = expand(problem, i, states, cost, batt_j, u, threads, buffers)
        n_evals += so.shape[0]
        inside = _inside(so[:, core.SOC], lo_win[i + 1], hi_win[i + 1], tube, i + 1)
        if heat_price is None or not np.any(heat_price[i + 1]):
            heat_g = buffers.no_heat[:so.shape[0]]
        else:
            heat_g = so[:, PRICED] @ heat_price[i + 1]
        widths = grid.stage_widths(None if heat_price is None else heat_price[i + 1])
        keep = survivors(so, inside, c, e, batt_g_per_j, SECOND_PRICE * batt_g_per_j, heat_g, widths, states.shape[0],
                         threads, keep_cool=not cheap_heat[i + 1],
                         price3=THIRD_PRICE * batt_g_per_j if third_price and cheap_heat[i + 1] else 0.0)
        if keep.size > 1:
            keep = non_dominated(so[keep], c[keep] + batt_g_per_j * e[keep], widths, keep,
                                 fuller_value=c[keep] + heat_g[keep] if cheap_heat[i + 1] else None)
        keep = np.sort(keep)
        if seed_at.size:
            keep, seed_at = _keep_seeds(keep, seed_at, seeds, u, i, so[:, core.SOC], (lo_win[i + 1], hi_win[i + 1]))
        states, cost, batt_j = so[keep], c[keep], e[keep]
        parents.append((keep // u.size).astype(np.int32))
        actions.append(a[keep].astype(np.float32))
        max_states = max(max_states, keep.size)
        if progress is not None:
            progress(i + 1, n, keep.size)
    return SearchResult(final_state=states, final_cost_g=cost, final_battery_j=batt_j, parents=parents, actions=actions,
                        grid=grid, solve_s=time.perf_counter() - t0, n_evals=n_evals, max_states=max_states,
                        info={"threads": threads, "final_soc_window": list(final_window), "tube": tube is not None})


def heat_prices(problem: DPProblem, u_ref: np.ndarray) -> np.ndarray:
    """Prices [n_stages + 1, len(PRICED)] (g/K) of the temperatures after each stage, along the path ``u_ref``: from
    every :data:`EVERY`-th stage the path's remaining actions replayed with one temperature ± :data:`DELTA_K`, the
    difference of the rest of the path's cost (plus the battery energy at the reward's price) over 2·ΔT, at least 0
    (cooler is never worse in this physics), linear between the sampled stages and 0 at the end."""
    n = problem.n_stages
    starts = np.arange(0, n, EVERY)
    rows = starts.size * len(PRICED) * 2
    start = np.repeat(starts, len(PRICED) * 2)
    col = np.tile(np.repeat(np.array(PRICED), 2), starts.size)
    sign = np.tile([1.0, -1.0], starts.size * len(PRICED))
    rp = problem.reward_params
    price = rp.prices.battery_g_per_j(problem.lhv) * rp.soc_energy_weight
    st = np.repeat(problem.state0[None, :], rows, axis=0)
    ref = problem.state0[None, :].copy()
    adj = np.zeros(rows)
    for k in range(n):
        new = start == k
        if np.any(new):
            st[new] = ref[0]
            st[new, col[new]] += sign[new] * DELTA_K
        active = start <= k
        so, out = problem.step(np.vstack([ref, st[active]]), np.full(1 + int(active.sum()), u_ref[k]), k)
        cost = stage_cost_g(rp, out, so, problem.soc_target, problem.lhv, problem.core.dt_s, battery=False,
                            overheat=True)
        adj[active] += cost[1:] + price * out[1:, core.BATT_CHEM] * problem.core.dt_s
        ref, st[active] = so[:1], so[1:]
    mu = np.maximum((adj[sign > 0] - adj[sign < 0]).reshape(starts.size, len(PRICED)) / (2.0 * DELTA_K), 0.0)
    # the price of the temperature after stage i: measured from the start of stage i + 1
    at = np.arange(n + 1)
    return np.column_stack([np.interp(at, np.r_[starts, n], np.r_[mu[:, d], 0.0]) for d in range(len(PRICED))])
