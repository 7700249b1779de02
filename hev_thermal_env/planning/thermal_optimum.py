"""The thermal optimum over a known cycle and its fuel-versus-final-SOC frontier (the ``dp_thermal`` planner).

The benchmark's yardstick: the forward search of :mod:`.search` in passes around the SOC DP's path (:mod:`.soc_dp`)
and the seeds' (causal strategies' runs of the same episode; the passes: docs/strategies.md). The plan is the cheapest
path into the final-SOC band of the last two passes (by the search's cost plus the battery energy at the reward's
price), an exact action sequence; the report's ``frontier``, over their final states, is the cost by final SOC within
``frontier_halfwidth`` of the target, which the benchmark divides each strategy's cost by at its own final SOC.

Solved plans are kept on disk (:func:`cached_plan`: JSON in ``plans/`` beside the compiled-kernel cache), under a hash
of the plan's key (:meth:`OptimumSettings.key`) and of the sources the planner runs, so an edit of any of them solves
afresh and an edit elsewhere does not.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import multiprocessing
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from hev_thermal_env.envs.reward import stage_cost_g
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.physics import core
from hev_thermal_env.physics.jit import CACHE_DIR, source_hash

from .problem import DPInfeasibleError, DPProblem
from .search import (
    LOCAL_HALFWIDTH,
    N_LOCAL,
    REFINE_STRIDE,
    SearchGrid,
    SearchResult,
    frontier_points,
    heat_prices,
    heat_stays_cheap,
    search,
    seed_splits,
)
from .soc_dp import DPSettings, rollout, solve

#: Cycles shorter than this (steps) get a proportionally narrower SOC bin (:meth:`OptimumSettings.grid_for`).
SHORT_CYCLE_STEPS = 600
#: The first pass's grid: every bin twice as wide, half the splits (:meth:`SearchGrid.scaled`).
FIRST_PASS_SCALE = 0.5
#: The third pass narrows the SOC bin until one bin of charge, priced and summed over the stages, is at most this
#: share of the cycle's cost (:meth:`OptimumSettings.refined_grid`) ...
BIN_BUDGET = 0.25
#: ... and keeps states within this much SOC of the second pass's path and of the DP's.
TUBE_HALFWIDTH = 0.01


def in_worker_process() -> bool:
    """True in a child process of ``multiprocessing`` (a pool worker), whose parent shows the progress."""
    return multiprocessing.parent_process() is not None


@dataclass(frozen=True)
class OptimumSettings:
    """What the thermal optimum is asked for (the ``dp_thermal`` strategy's options); ``fixed_soc_bin``: the SOC bin
    was given, so it is not narrowed on short or cheap cycles."""

    grid: SearchGrid = SearchGrid()
    fixed_soc_bin: bool = False
    soc_final: float | None = None
    soc_tol: float = 0.005
    on_infeasible: str = "raise"
    frontier_halfwidth: float = 0.08
    threads: int | None = field(default=None, repr=False, compare=False)  # the same plan on any number

    def key(self, problem: DPProblem) -> str:
        """What makes a plan: the problem and every setting that changes it."""
        return problem.key() + repr(dataclasses.replace(self, grid=self.grid_for(problem.n_stages)))

    def grid_for(self, n_stages: int) -> SearchGrid:
        """The grid of a cycle of ``n_stages`` steps: below 600 steps the SOC bin narrows with the cycle (at most
        10×, unless ``fixed_soc_bin``). A bin of charge is worth a fixed number of grams (≈1.4 g at 1.5·10⁻⁴), so on a
        short cycle it would be a larger share of the cost."""
        if self.fixed_soc_bin:
            return self.grid
        return dataclasses.replace(self.grid, soc=self.grid.soc * min(max(n_stages / SHORT_CYCLE_STEPS, 0.1), 1.0))

    def refined_grid(self, grid: SearchGrid, first: SearchResult, problem: DPProblem, cost_g: float) -> SearchGrid:
        """The refining pass's grid: the SOC bin narrowed until one bin of charge, priced, summed over the stages is at
        most :data:`BIN_BUDGET` of the cycle's cost (at most 5× narrower)."""
        if self.fixed_soc_bin:
            return grid
        soc, e = first.final_state[:, core.SOC], first.final_battery_j
        if soc.size < 3 or np.ptp(soc) <= 0.0:
            return grid
        j_per_soc = -np.polyfit(soc, e, 1)[0]
        bin_g = grid.soc * j_per_soc * problem.reward_params.prices.battery_g_per_j(problem.lhv)
        if not (bin_g > 0.0 and cost_g > 0.0):
            return grid
        factor = min(max(BIN_BUDGET * cost_g / (bin_g * problem.n_stages), 0.2), 1.0)
        return dataclasses.replace(grid, soc=grid.soc * factor)


@dataclass
class OptimumPlan:
    """A planned action sequence, its report (in the strategy's ``describe()``) and the finest grid searched."""

    u: np.ndarray
    report: dict[str, Any]
    grid: SearchGrid


def adjusted_cost(result: SearchResult, problem: DPProblem) -> np.ndarray:
    """Cost of every final survivor plus its battery energy at the reward's price (g): what picks the plan."""
    rp = problem.reward_params
    return result.final_cost_g + rp.soc_energy_weight * rp.prices.battery_g_per_j(problem.lhv) * result.final_battery_j


def pick_final(result: SearchResult, problem: DPProblem, band: tuple[float, float], on_infeasible: str) -> int:
    """The final survivor to drive to: cheapest (cost + battery energy at the reward's price) in ``band``."""
    soc = result.final_state[:, core.SOC]
    adj = adjusted_cost(result, problem)
    inside = np.flatnonzero((soc >= band[0]) & (soc <= band[1]))
    if inside.size:
        return int(inside[np.argmin(adj[inside])])
    if on_infeasible == "raise":
        raise DPInfeasibleError(
            f"dp_thermal: no path on cycle {problem.name!r} ends in the final-SOC band [{band[0]:.4f}, {band[1]:.4f}]; "
            f"planned paths end in [{soc.min():.4f}, {soc.max():.4f}] (change soc_final or soc_tol, or pass "
            f"on_infeasible='closest')")
    dist = np.maximum(band[0] - soc, soc - band[1])
    near = np.flatnonzero(dist <= dist.min() + 1e-12)
    return int(near[np.argmin(adj[near])])


def replay(problem: DPProblem, u: np.ndarray) -> dict[str, np.ndarray]:
    """Drive the action sequence ``u`` on the physics from the start: states, outputs and the yardstick cost."""
    n = u.size
    states = np.empty((n + 1, core.N_STATE))
    outs = np.empty((n, core.N_OUT))
    states[0] = problem.state0
    for i in range(n):
        st, out = problem.step(states[i:i + 1], u[i], i)
        states[i + 1], outs[i] = st[0], out[0]
    cost = stage_cost_g(problem.reward_params, outs, states[1:], problem.soc_target, problem.lhv,
                        problem.core.dt_s, battery=False, overheat=True)
    return {"state": states, "out": outs, "cost_g": float(cost.sum())}


def _search(problem: DPProblem, grid: SearchGrid, window: tuple[float, float], label: str, threads: int | None,
            **refine: Any) -> SearchResult:
    """:func:`~.search.search` with a bar of its stages on stderr (hidden off a terminal and in worker processes)."""
    hidden = True if in_worker_process() else None  # None: tqdm hides it off a terminal
    with tqdm(total=problem.n_stages, desc=f"dp_thermal {problem.name}: {label}", unit="stage", leave=False,
              disable=hidden) as bar:

        def progress(stage: int, n_stages: int, n_states: int) -> None:
            bar.set_postfix_str(f"{n_states} states", refresh=False)
            bar.update()

        return search(problem, grid, window, threads=threads, progress=progress, **refine)


def plan_optimum(problem: DPProblem, s: OptimumSettings, seeds: dict[str, np.ndarray] | None = None) -> OptimumPlan:
    """Search the passes (see the module docstring) and return the plan into the final-SOC band. ``seeds``: driven
    action sequences by name (a causal strategy's run of the same episode), each kept alive through every pass and
    a centre of the refining passes, so no seed ends cheaper than the frontier at its own final SOC."""
    t0 = time.perf_counter()
    seed_u = None if not seeds else seed_splits(problem, np.array(list(seeds.values())))
    seed_runs = {} if seed_u is None else {name: replay(problem, u) for name, u in zip(seeds, seed_u)}
    grid = s.grid_for(problem.n_stages)
    target = float(problem.state0[core.SOC]) if s.soc_final is None else float(s.soc_final)
    window = (target - s.frontier_halfwidth, target + s.frontier_halfwidth)
    band = (target - s.soc_tol, target + s.soc_tol)
    # the SOC-state DP's path (thermal state held while planning, driven free): a centre of the refining passes
    dp_settings = DPSettings(soc_final=target, soc_tol=s.soc_tol, on_infeasible="closest", threads=s.threads)
    dp_run = rollout(solve(problem, dp_settings), problem, dp_settings, free=True)
    dp_u, dp_soc = np.asarray(dp_run["u"], dtype=np.float64), dp_run["state"][:, core.SOC].copy()
    t_heat = time.perf_counter()
    heat_dp = heat_prices(problem, dp_u)
    heat_s = time.perf_counter() - t_heat
    if heat_stays_cheap(grid, heat_dp, problem.n_stages)[0]:  # the thermal-blind path is as good a centre
        searched0: list[SearchResult] = []
        centers, heat = [dp_u], heat_dp
        first_pass: dict[str, Any] = {"skipped": "heat stays cheap along dp's path", "heat_prices_s": heat_s}
    else:
        first = _search(problem, grid.scaled(FIRST_PASS_SCALE), window, "pass 1", s.threads, heat_price=heat_dp,
                        seeds=seed_u)
        searched0 = [first]
        j_first = pick_final(first, problem, band, s.on_infeasible)
        first_pass = {"solve_s": first.solve_s, "cost_g": float(first.final_cost_g[j_first])}
        centers = [first.path(j_first), dp_u]
        t_heat = time.perf_counter()
        heat = heat_prices(problem, centers[0])
        first_pass["heat_prices_s"] = heat_s + time.perf_counter() - t_heat
    first_pass["heat_price_g_per_k_max"] = dict(zip(("motor", "winding", "coolant"), heat.max(axis=0).tolist()))
    # the refining passes make the plan and the frontier; where the coarse pass was skipped, pass 2 keeps a third price
    passes, grid = _refine(problem, s, grid, window, band, centers, dp_soc, heat, third_price=not searched0,
                           seeds=seed_u, seed_soc=[r["state"][:, core.SOC] for r in seed_runs.values()])
    searched = searched0 + passes
    result, j = _pick(passes, problem, band, s.on_infeasible)
    u = result.path(j)
    run = replay(problem, u)
    soc_f, cost_f = frontier_points(np.concatenate([r.final_state[:, core.SOC] for r in passes]),
                                    np.concatenate([r.final_cost_g for r in passes]))
    report = {
        "planned_cost_g": float(result.final_cost_g[j]), "replayed_cost_g": run["cost_g"],
        "planned_soc_final": float(result.final_state[j, core.SOC]),
        "planned_fuel_g": float(run["out"][:, core.FUEL_G].sum()),
        "solve_s": sum(r.solve_s for r in searched), "plan_total_s": time.perf_counter() - t0,
        "first_pass": first_pass,
        "seeds": {name: {"cost_g": r["cost_g"], "soc_final": float(r["state"][-1, core.SOC])}
                  for name, r in seed_runs.items()},
        "passes": [{"solve_s": r.solve_s, "soc_bin": r.grid.soc, "max_states": r.max_states,
                    "tube": r.info.get("tube", False)} for r in searched],
        "vehicle_steps_evaluated": int(sum(r.n_evals for r in searched)),
        "max_states": int(max(r.max_states for r in searched)),
        "frontier": {"soc_final": soc_f.tolist(), "cost_g": cost_f.tolist(),
                     "grid": grid.describe() + f" (every {REFINE_STRIDE}. split) + {N_LOCAL} splits within "
                                               f"±{LOCAL_HALFWIDTH:g} of {len(centers) + len(seeds or {})} earlier "
                                               f"path(s)",
                     "soc_min": float(min(r.final_state[:, core.SOC].min() for r in passes)),
                     "cost": "fuel + missed wheel energy at the miss price + the reward's overheat terms (g)"},
    }
    return OptimumPlan(u=u, report=report, grid=grid)


def _refine(problem: DPProblem, s: OptimumSettings, grid: SearchGrid, window: tuple[float, float],
            band: tuple[float, float], centers: list[np.ndarray], dp_soc: np.ndarray,
            heat: np.ndarray, third_price: bool, seeds: np.ndarray | None = None,
            seed_soc: list[np.ndarray] = ()) -> tuple[list[SearchResult], SearchGrid]:
    """The second pass around ``centers`` and, where :meth:`OptimumSettings.refined_grid` narrows the SOC bin, the
    third pass in a SOC tube around the second pass's best path and the DP's; returns them and the finest grid used.
    ``third_price``: the second pass keeps a bin's cheapest at :data:`~.search.THIRD_PRICE` where heat stays cheap
    (it spans the whole window, where a frontier far from the plan comes from; the tube around the plan needs none).
    ``seeds`` are centres too, and the tube holds their SOC traces (``seed_soc``)."""
    extra = [] if seeds is None else list(seeds)
    second = _search(problem, grid, window, "pass 2", s.threads, u_center=np.array(centers + extra), heat_price=heat,
                     third_price=third_price, seeds=seeds)
    j2 = pick_final(second, problem, band, s.on_infeasible)
    fine = s.refined_grid(grid, second, problem, float(second.final_cost_g[j2]))
    if not fine.soc < grid.soc:
        return [second], grid
    u2 = second.path(j2)
    socs = [replay(problem, u2)["state"][:, core.SOC], *seed_soc, dp_soc]
    tube = (np.min(socs, axis=0) - TUBE_HALFWIDTH, np.max(socs, axis=0) + TUBE_HALFWIDTH)
    third = _search(problem, fine, window, "pass 3", s.threads, u_center=np.array([u2] + centers[1:] + extra),
                    tube=tube, heat_price=heat, seeds=seeds)
    return [second, third], fine


def _pick(passes: list[SearchResult], problem: DPProblem, band: tuple[float, float],
          on_infeasible: str) -> tuple[SearchResult, int]:
    """The pass and final survivor to drive to: the cheapest path into ``band`` (cost + battery energy at the
    reward's price) over the passes; a pass after the first counts only where it reaches the band."""
    picks = [(passes[0], pick_final(passes[0], problem, band, on_infeasible))]
    for r in passes[1:]:
        try:
            picks.append((r, pick_final(r, problem, band, "raise")))
        except DPInfeasibleError:
            pass
    return min(picks, key=lambda rj: adjusted_cost(rj[0], problem)[rj[1]])


_told = False


def cached_plan(problem: DPProblem, settings: OptimumSettings, use_cache: bool = True,
                seeds: dict[str, np.ndarray] | None = None) -> OptimumPlan:
    """The plan of ``problem`` (and ``seeds``, :func:`plan_optimum`): read from disk if it was solved before (its report
    then says ``from_cache``), else solved and kept (``use_cache=False``: always solved, not kept)."""
    grid = settings.grid_for(problem.n_stages)
    path = None
    if use_cache and CACHE_DIR is not None:
        key = settings.key(problem) + source_hash([__name__])
        if seeds:  # their names and float32 actions
            h = hashlib.sha256()
            for name, u in seeds.items():
                h.update(name.encode() + np.ascontiguousarray(u, dtype="<f4").tobytes())
            key += "seeds:" + h.hexdigest()
        path = CACHE_DIR.parent / "plans" / f"dp_thermal-{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"
    if path is not None and path.is_file():
        try:
            data = json.loads(path.read_text())
            return OptimumPlan(u=np.asarray(data["u"], dtype=np.float64), report=dict(data["report"], from_cache=True),
                               grid=grid)
        except (OSError, ValueError, KeyError):
            pass
    plan = plan_optimum(problem, settings, seeds)
    if path is not None:
        try:
            atomic_write_json(path, {"u": plan.u.tolist(), "report": plan.report})
        except OSError:
            return plan
        global _told
        if not _told and not in_worker_process():  # said once per process, not in pool workers
            _told = True
            tqdm.write(f"dp_thermal: plan kept in {path.parent}/ and reused whenever the same cycle, start, vehicle "
                       f"and settings come again (plan_cache=False solves afresh)", file=sys.stderr)
    return plan
