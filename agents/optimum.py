"""``dp_thermal``: the thermal optimum over the known cycle, the yardstick of the benchmark.

The planner is :mod:`hev_thermal_env.planning.thermal_optimum` (the passes, the cost, the
frontier); a solved plan is kept on disk and reused (:mod:`hev_thermal_env.planning.plan_cache`).
The strategy drives the planned action sequence; ``describe()`` reports the planned and replayed
cost, the grid and the frontier (the cost as a function of final SOC).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.planning.plan_cache import cached_plan
from hev_thermal_env.planning.problem import DPProblem
from hev_thermal_env.planning.search import SearchGrid
from hev_thermal_env.planning.thermal_optimum import OptimumPlan, OptimumSettings

from .base import Strategy


class ThermalOptimumStrategy(Strategy):
    """The thermal optimum (see :mod:`hev_thermal_env.planning.thermal_optimum`).

    Options: ``grid_scale`` (every bin divided by it, splits multiplied), the bin widths
    ``soc_bin``, ``winding_bin_k``, ``housing_bin_k``, ``coolant_bin_k``, ``heat_index_bin``,
    ``n_u`` (splits), ``soc_final`` (default: the initial SOC) and ``soc_tol``, ``on_infeasible``
    (``"raise"`` or ``"closest"``), ``frontier_halfwidth`` (final SOCs kept around the target),
    ``dominance`` (drop states dominated within their SOC bin), ``refine`` (the second pass; without it
    one pass on the full grid), ``first_pass_scale`` (the first pass's grid, :meth:`SearchGrid.scaled`),
    ``refine_global_stride`` (every k-th uniform split in the second pass), ``seed_dp`` (also refine
    around the SOC-state DP's path), ``n_local`` splits within ± ``local_halfwidth`` of each path,
    ``bin_budget`` (the third pass's SOC bin; None keeps the bin), ``plan_cache`` (reuse a plan solved
    before for the same problem, settings and planner sources), ``threads``.
    """

    name = "dp_thermal"
    thermal_aware = True

    def __init__(self, grid_scale: float = 1.0, soc_bin: float | None = None, winding_bin_k: float | None = None,
                 housing_bin_k: float | None = None, coolant_bin_k: float | None = None,
                 heat_index_bin: float | None = None, n_u: int | None = None, soc_final: float | None = None,
                 soc_tol: float = 0.005, on_infeasible: str = "raise", frontier_halfwidth: float = 0.08,
                 dominance: bool = True, refine: bool = True, local_halfwidth: float = 0.05, n_local: int = 21,
                 first_pass_scale: float = 0.5, refine_global_stride: int = 2, seed_dp: bool = True,
                 bin_budget: float | None = 0.25, plan_cache: bool = True, threads: int | None = None):
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
        self.settings = OptimumSettings(
            grid=SearchGrid(**{**base.__dict__, **fields}), fixed_soc_bin=soc_bin is not None, soc_final=soc_final,
            soc_tol=float(soc_tol), on_infeasible=on_infeasible, frontier_halfwidth=float(frontier_halfwidth),
            refine=bool(refine), local_halfwidth=float(local_halfwidth), n_local=int(n_local),
            first_pass_scale=float(first_pass_scale), refine_global_stride=int(refine_global_stride),
            seed_dp=bool(seed_dp), bin_budget=None if bin_budget is None else float(bin_budget), threads=threads)
        self.plan_cache = bool(plan_cache)
        self.plan: OptimumPlan | None = None
        self._key: str | None = None
        self._k0 = 0

    def plan_for(self, problem: DPProblem) -> np.ndarray:
        """Search (or reuse the plan of the same problem) and return the planned action sequence."""
        key = self.settings.key(problem)
        if self.plan is None or key != self._key:
            self.plan, self._key = cached_plan(problem, self.settings, self.plan_cache), key
        return self.plan.u

    def reset(self, env: Any) -> None:
        super().reset(env)
        problem = DPProblem.from_env(self.env)
        self._k0 = problem.k0
        self.plan_for(problem)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        u = self.plan.u
        i = int(self.env.k) - self._k0
        return np.array([float(u[i]) if 0 <= i < u.size else 0.0], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        s = self.settings
        g = self.plan.grid if self.plan is not None else s.grid
        return {
            "name": self.name, "method": g.describe(),
            "state": ["soc", "motor_temp_c", "housing_temp_c", "coolant_temp_c", "heat_x", "motor_cutoff"],
            "grid": {"soc": g.soc, "winding_k": g.winding_k, "housing_k": g.housing_k, "coolant_k": g.coolant_k,
                     "heat_index": g.heat_index, "n_u": g.n_u, "dominance": g.dominance, "refine": s.refine,
                     "n_local": s.n_local, "local_halfwidth": s.local_halfwidth,
                     "first_pass_scale": s.first_pass_scale, "refine_global_stride": s.refine_global_stride,
                     "seed_dp": s.seed_dp, "bin_budget": s.bin_budget},
            "soc_tol": s.soc_tol, "on_infeasible": s.on_infeasible,
            "frontier_halfwidth": s.frontier_halfwidth, "thermal_planning": "exact state (forward search)",
            **(self.plan.report if self.plan is not None else {}),
        }
