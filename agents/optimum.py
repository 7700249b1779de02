"""``dp_thermal``: the thermal optimum over a known cycle, and its fuel-versus-final-SOC frontier.

The yardstick of the benchmark. It plans over the whole state that matters (SOC, the thermal
network's winding, housing and coolant temperatures, the heat-index integrator and the cutoff
flag) with the environment's own physics core and reward, by the forward search of
:mod:`.optimum_search`, then drives the cheapest planned path that ends in the final-SOC band
(default: the initial SOC ± 0.005). The path is an exact action sequence, so in the environment
it realises the planned cost (the physics is deterministic; ``describe()`` reports both).

Cost. The search prices fuel, missed wheel energy and the reward's overheat terms (soft
temperature limit, cutoff, derate weight); within the band the path is chosen by that cost plus
the battery energy at the reward's battery price, as the SOC-state ``dp`` and the reward do.
``describe()["frontier"]`` is the cost as a function of final SOC over ``frontier_halfwidth``
around the target: the benchmark divides each strategy's cost by the frontier at the strategy's
own final SOC (comparison at equal charge, no battery price involved).

Passes. A first, coarse pass (every bin twice as wide, 17 splits: ``first_pass_scale``) finds a
path into the band; the SOC-state ``dp`` (thermal-blind, about a second) gives another. The
second pass covers the whole frontier window: bins of ΔSOC 1.5·10⁻⁴, winding 4 K, housing 2 K,
coolant 4 K, heat index 0.1 (:class:`~.optimum_search.SearchGrid`), every second of the 31
uniform splits (``refine_global_stride``) and 21 splits within ±0.05 of each of the two paths at
every stage (``n_local``, ``local_halfwidth``). On cycles with a low cost per second (city buses)
a third pass narrows the SOC bin (at most 5×) until one bin of charge, priced and summed over the
stages, is at most ``bin_budget`` (25 %) of the cost: a bin's pruning error is paid once per
stage, so it weighs more where each second costs little. To stay affordable the third pass keeps
only states within ±0.01 SOC of the second pass's best path and of ``dp``'s path, around which it
refines. The plan is the cheapest path into the band of the last two passes; the frontier is
taken over the final states of both. ``grid_scale=2`` halves every bin and doubles the split grid.

Error. The error comes from pruning, not interpolation. ``benchmarks/optimum.py`` measures it
(grid doubling; a much finer search on short cycles) and checks that no strategy of the project
ends below the frontier.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.jit import CACHE_DIR, source_hash

from .base import Strategy
from .common import stage_cost_g
from .dp import DPStrategy, rollout
from .dp_grid import DPInfeasibleError, DPProblem
from .optimum_search import SearchGrid, SearchResult, frontier_points, search

__all__ = ["ThermalOptimumStrategy", "pick_final", "replay"]

#: Cycles shorter than this (steps) get a proportionally narrower SOC bin (:meth:`ThermalOptimumStrategy.grid_for`).
SHORT_CYCLE_STEPS = 600
#: The third pass keeps states within this much SOC of the second pass's path and of ``dp``'s.
TUBE_HALFWIDTH = 0.01


def adjusted_cost(result: SearchResult, problem: DPProblem) -> np.ndarray:
    """Cost of every final survivor plus its battery energy at the reward's price (g): what picks the plan."""
    rp = problem.reward_params
    return result.final_cost_g + rp.soc_energy_weight * rp.prices.battery_g_per_j(problem.lhv) * result.final_battery_j


def pick_final(result: SearchResult, problem: DPProblem, band: tuple[float, float], on_infeasible: str) -> int:
    """The final survivor to drive to: cheapest (cost + battery energy at the reward's price) in ``band``."""
    soc = result.final_state[:, C.SOC]
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


def soc_dp_path(problem: DPProblem, target: float, soc_tol: float,
                threads: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The SOC-state ``dp``'s (thermal state held) action sequence on ``problem`` and its SOC trace: a centre for
    the refining passes."""
    dp = DPStrategy(soc_final=target, soc_tol=soc_tol, on_infeasible="closest", threads=threads)
    run = rollout(dp.plan_for(problem), problem, dp.settings, free=True)
    return np.asarray(run["u"], dtype=np.float64), run["state"][:, C.SOC].copy()


def replay(problem: DPProblem, u: np.ndarray) -> dict[str, np.ndarray]:
    """Drive the action sequence ``u`` on the physics from the start: states, outputs and the yardstick cost."""
    n = u.size
    st = problem.state0[None, :].copy()
    states = np.empty((n + 1, C.N_STATE))
    outs = np.empty((n, C.N_OUT))
    states[0] = st[0]
    for i in range(n):
        st, out = problem.step(st, np.array([u[i]]), i)
        states[i + 1], outs[i] = st[0], out[0]
    cost = stage_cost_g(problem.reward_params, outs, states[1:], problem.soc_target, problem.lhv,
                        problem.core.dt_s, battery=False, overheat=True)
    return {"state": states, "out": outs, "cost_g": float(cost.sum())}


class ThermalOptimumStrategy(Strategy):
    """The thermal optimum (see the module docstring).

    Options: ``grid_scale`` (every bin divided by it, splits multiplied), the bin widths
    ``soc_bin``, ``winding_bin_k``, ``housing_bin_k``, ``coolant_bin_k``, ``heat_index_bin``,
    ``n_u`` (splits), ``soc_final`` (default: the initial SOC) and ``soc_tol``, ``on_infeasible``
    (``"raise"`` or ``"closest"``), ``frontier_halfwidth`` (final SOCs kept around the target),
    ``dominance`` (drop states dominated within their SOC bin), ``refine`` (the second pass; without it
    one pass on the full grid), ``first_pass_scale`` (the first pass's grid, :meth:`SearchGrid.scaled`),
    ``refine_global_stride`` (every k-th uniform split in the second pass), ``seed_dp`` (also refine
    around the SOC-state ``dp``'s path), ``n_local`` splits within ± ``local_halfwidth`` of each path,
    ``bin_budget`` (see the module docstring; None keeps the bin),
    ``plan_cache`` (reuse a plan solved before for the same problem, settings and kernel sources,
    kept in the compiled-kernel cache's parent directory), ``threads``.
    """

    name = "dp_thermal"
    thermal_aware = True

    def __init__(self, grid_scale: float = 1.0, soc_bin: float | None = None, winding_bin_k: float | None = None,
                 housing_bin_k: float | None = None, coolant_bin_k: float | None = None,
                 heat_index_bin: float | None = None, n_u: int | None = None, soc_final: float | None = None,
                 soc_tol: float = 0.005, on_infeasible: str = "raise", frontier_halfwidth: float = 0.08,
                 dominance: bool = True, refine: bool = True, local_halfwidth: float = 0.05, n_local: int = 21,
                 first_pass_scale: float = 0.5, refine_global_stride: int = 2, seed_dp: bool = True,
                 bin_budget: float | None = 0.25, plan_cache: bool = True, threads: int | None = None, **extra: Any):
        if extra:
            raise ValueError(f"{self.name}: unknown option(s) {sorted(extra)}")
        if on_infeasible not in ("raise", "closest"):
            raise ValueError(f"{self.name}: on_infeasible {on_infeasible!r} is not one of ['raise', 'closest']")
        if not grid_scale > 0.0:
            raise ValueError(f"{self.name}: grid_scale must be > 0, got {grid_scale}")
        if soc_tol < 0.0 or not frontier_halfwidth > soc_tol:
            raise ValueError(f"{self.name}: need 0 <= soc_tol < frontier_halfwidth, got {soc_tol}, "
                             f"{frontier_halfwidth}")
        bad_budget = bin_budget is not None and not bin_budget > 0.0
        if not first_pass_scale > 0.0 or int(refine_global_stride) < 1 or bad_budget:
            raise ValueError(f"{self.name}: need first_pass_scale > 0, refine_global_stride >= 1 and bin_budget > 0 "
                             f"(or None), got {first_pass_scale}, {refine_global_stride}, {bin_budget}")
        base = SearchGrid(dominance=bool(dominance)).scaled(float(grid_scale))
        given = {"soc": soc_bin, "winding_k": winding_bin_k, "housing_k": housing_bin_k, "coolant_k": coolant_bin_k,
                 "heat_index": heat_index_bin, "n_u": n_u}
        for key, value in given.items():
            if value is not None and not value > (1 if key == "n_u" else 0):
                raise ValueError(f"{self.name}: {key} must be {'at least 2' if key == 'n_u' else '> 0'}, got {value}")
        fields = {k: (int(v) if k == "n_u" else float(v)) for k, v in given.items() if v is not None}
        self.grid = SearchGrid(**{**base.__dict__, **fields})
        self._soc_bin_given = soc_bin is not None
        self.soc_final, self.soc_tol, self.on_infeasible = soc_final, float(soc_tol), on_infeasible
        self.frontier_halfwidth, self.threads = float(frontier_halfwidth), threads
        self.refine, self.local_halfwidth, self.n_local = bool(refine), float(local_halfwidth), int(n_local)
        self.plan_cache = bool(plan_cache)
        self.first_pass_scale, self.refine_global_stride = float(first_pass_scale), int(refine_global_stride)
        self.seed_dp = bool(seed_dp)
        self.bin_budget = None if bin_budget is None else float(bin_budget)
        self.result: SearchResult | None = None
        self.u_plan = np.zeros(0)
        self._k0 = 0
        self._key: str | None = None
        self._report: dict[str, Any] = {}
        self._grid_used = self.grid

    def plan_for(self, problem: DPProblem) -> np.ndarray:
        """Search (or reuse the last search for the same problem) and return the planned action sequence."""
        grid = self.grid_for(problem.n_stages)
        key = problem.key() + repr((grid, self.soc_final, self.soc_tol, self.frontier_halfwidth, self.refine,
                                    self.local_halfwidth, self.n_local, self.first_pass_scale,
                                    self.refine_global_stride, self.seed_dp,
                                    self.bin_budget, self.on_infeasible))
        if key == self._key:
            return self.u_plan
        cached = self._load(key)
        if cached is not None:
            self.u_plan, self._report, self._key, self._grid_used = cached[0], cached[1], key, grid
            return self.u_plan
        t0 = time.perf_counter()
        target = float(problem.state0[C.SOC]) if self.soc_final is None else float(self.soc_final)
        window = (target - self.frontier_halfwidth, target + self.frontier_halfwidth)
        band = (target - self.soc_tol, target + self.soc_tol)
        first_grid = grid.scaled(self.first_pass_scale) if self.refine else grid
        first = search(problem, first_grid, window, threads=self.threads)
        j_first = pick_final(first, problem, band, self.on_infeasible)
        first_pass = {"solve_s": first.solve_s, "cost_g": float(first.final_cost_g[j_first])}
        centers = [first.path(j_first)]
        passes = [first]  # the passes whose final states make the plan and the frontier
        if self.refine:
            dp_soc = None
            if self.seed_dp:
                dp_u, dp_soc = soc_dp_path(problem, target, self.soc_tol, self.threads)
                centers.append(dp_u)
            passes, grid = self._refine(problem, grid, window, band, centers, dp_soc)
        searched = [first] + passes if self.refine else passes
        result, j = self._pick(passes, problem, band)
        u = result.path(j)
        run = replay(problem, u)
        soc_f, cost_f = frontier_points(np.concatenate([r.final_state[:, C.SOC] for r in passes]),
                                        np.concatenate([r.final_cost_g for r in passes]))
        self._report = {
            "planned_cost_g": float(result.final_cost_g[j]), "replayed_cost_g": run["cost_g"],
            "planned_soc_final": float(result.final_state[j, C.SOC]),
            "planned_fuel_g": float(run["out"][:, C.FUEL_G].sum()),
            "solve_s": sum(r.solve_s for r in searched), "plan_total_s": time.perf_counter() - t0,
            "first_pass": first_pass,
            "passes": [{"solve_s": r.solve_s, "soc_bin": r.grid.soc, "max_states": r.max_states,
                        "tube": r.info.get("tube", False)} for r in searched],
            "vehicle_steps_evaluated": int(sum(r.n_evals for r in searched)),
            "max_states": int(max(r.max_states for r in searched)),
            "frontier": {"soc_final": soc_f.tolist(), "cost_g": cost_f.tolist(),
                         "grid": grid.describe() + (f" (every {self.refine_global_stride}. split) + {self.n_local} "
                                                    f"splits within ±{self.local_halfwidth:g} of "
                                                    f"{len(centers)} earlier path(s)" if self.refine else ""),
                         "soc_min": float(min(r.final_state[:, C.SOC].min() for r in passes)),
                         "cost": "fuel + missed wheel energy at the miss price + the reward's overheat terms (g)"},
        }
        self.result, self.u_plan, self._key, self._grid_used = result, u, key, grid
        self._store(key)
        return u

    def _refine(self, problem: DPProblem, grid: SearchGrid, window: tuple[float, float], band: tuple[float, float],
                centers: list[np.ndarray], dp_soc: np.ndarray | None) -> tuple[list[SearchResult], SearchGrid]:
        """The second pass around ``centers`` and, where :meth:`refined_grid` narrows the SOC bin, the third pass in
        a SOC tube around the second pass's best path and ``dp``'s; returns them and the finest grid used."""
        refine = dict(threads=self.threads, local_halfwidth=self.local_halfwidth, n_local=self.n_local,
                      global_stride=self.refine_global_stride)
        second = search(problem, grid, window, u_center=np.array(centers), **refine)
        j2 = pick_final(second, problem, band, self.on_infeasible)
        fine = self.refined_grid(grid, second, problem, float(second.final_cost_g[j2]))
        if not fine.soc < grid.soc:
            return [second], grid
        u2 = second.path(j2)
        socs = [replay(problem, u2)["state"][:, C.SOC]] + ([] if dp_soc is None else [dp_soc])
        tube = (np.min(socs, axis=0) - TUBE_HALFWIDTH, np.max(socs, axis=0) + TUBE_HALFWIDTH)
        third = search(problem, fine, window, u_center=np.array([u2] + centers[1:]), tube=tube, **refine)
        return [second, third], fine

    def _pick(self, passes: list[SearchResult], problem: DPProblem,
              band: tuple[float, float]) -> tuple[SearchResult, int]:
        """The pass and final survivor to drive to: the cheapest path into ``band`` (cost + battery energy at the
        reward's price) over the passes; a pass after the first counts only where it reaches the band."""
        picks = [(passes[0], pick_final(passes[0], problem, band, self.on_infeasible))]
        for r in passes[1:]:
            try:
                picks.append((r, pick_final(r, problem, band, "raise")))
            except DPInfeasibleError:
                pass
        return min(picks, key=lambda rj: adjusted_cost(rj[0], problem)[rj[1]])

    # -- a solved plan is kept on disk: the same cycle, start, vehicle, reward and settings on the same kernel
    # sources reuse it (``plan_cache: false`` to always solve) --------------------------------------------------
    def _cache_path(self, key: str) -> Path | None:
        if not self.plan_cache or CACHE_DIR is None:
            return None
        h = hashlib.sha256((key + source_hash()).encode())
        h.update(Path(__file__).read_bytes())  # the planner's own code (pick, replay, report) too
        digest = h.hexdigest()[:32]
        return CACHE_DIR.parent / "plans" / f"dp_thermal-{digest}.json"

    def _load(self, key: str) -> tuple[np.ndarray, dict] | None:
        path = self._cache_path(key)
        if path is None or not path.is_file():
            return None
        try:
            data = json.loads(path.read_text())
            return np.asarray(data["u"], dtype=np.float64), dict(data["report"], from_cache=True)
        except (OSError, ValueError, KeyError):
            return None

    def _store(self, key: str) -> None:
        path = self._cache_path(key)
        if path is None:
            return
        try:
            atomic_write_json(path, {"u": self.u_plan.tolist(), "report": self._report})
        except OSError:
            pass

    def refined_grid(self, grid: SearchGrid, first: SearchResult, problem: DPProblem, cost_g: float) -> SearchGrid:
        """The refining pass's grid: the SOC bin narrowed until one bin of charge, priced, summed over the stages is at
        most ``bin_budget`` of the cycle's cost (at most 5× narrower)."""
        if self.bin_budget is None or self._soc_bin_given:
            return grid
        soc, e = first.final_state[:, C.SOC], first.final_battery_j
        if soc.size < 3 or np.ptp(soc) <= 0.0:
            return grid
        j_per_soc = -np.polyfit(soc, e, 1)[0]
        rp = problem.reward_params
        bin_g = grid.soc * j_per_soc * rp.prices.battery_g_per_j(problem.lhv)
        if not (bin_g > 0.0 and cost_g > 0.0):
            return grid
        factor = min(max(self.bin_budget * cost_g / (bin_g * problem.n_stages), 0.2), 1.0)
        return dataclasses.replace(grid, soc=grid.soc * factor)

    def grid_for(self, n_stages: int) -> SearchGrid:
        """The grid of a cycle of ``n_stages`` steps: below 600 steps the SOC bin narrows with the cycle (at most
        10×, unless ``soc_bin`` was given). A bin of charge is worth a fixed number of grams (≈1.4 g at
        1.5·10⁻⁴), so on a short cycle it would be a larger share of the cost."""
        if self._soc_bin_given:
            return self.grid
        return dataclasses.replace(self.grid, soc=self.grid.soc * min(max(n_stages / SHORT_CYCLE_STEPS, 0.1), 1.0))

    def reset(self, env: Any) -> None:
        super().reset(env)
        problem = DPProblem.from_env(self.env)
        self._k0 = problem.k0
        self.plan_for(problem)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        i = int(self.env.k) - self._k0
        u = float(self.u_plan[i]) if 0 <= i < self.u_plan.size else 0.0
        return np.array([u], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        g = self._grid_used
        return {
            "name": self.name, "method": g.describe(),
            "state": ["soc", "motor_temp_c", "housing_temp_c", "coolant_temp_c", "heat_x", "motor_cutoff"],
            "grid": {"soc": g.soc, "winding_k": g.winding_k, "housing_k": g.housing_k, "coolant_k": g.coolant_k,
                     "heat_index": g.heat_index, "n_u": g.n_u, "dominance": g.dominance, "refine": self.refine,
                     "n_local": self.n_local, "local_halfwidth": self.local_halfwidth,
                     "first_pass_scale": self.first_pass_scale, "refine_global_stride": self.refine_global_stride,
                     "seed_dp": self.seed_dp, "bin_budget": self.bin_budget},
            "soc_tol": self.soc_tol, "on_infeasible": self.on_infeasible,
            "frontier_halfwidth": self.frontier_halfwidth, "thermal_planning": "exact state (forward search)",
            **self._report,
        }
