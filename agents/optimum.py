"""``dp_thermal``: the thermal optimum over the known cycle (:mod:`hev_thermal_env.planning.thermal_optimum`), the
benchmark's yardstick. A solved plan is kept on disk and reused (its ``cached_plan``).
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any

import numpy as np

from hev_thermal_env.planning.problem import DPProblem
from hev_thermal_env.planning.search import LOCAL_HALFWIDTH, N_LOCAL, REFINE_STRIDE, SearchGrid
from hev_thermal_env.planning.thermal_optimum import (
    BIN_BUDGET,
    FIRST_PASS_SCALE,
    OptimumPlan,
    OptimumSettings,
    cached_plan,
)

from .base import Strategy, register, registered, strategy_class


@register
class ThermalOptimumStrategy(Strategy):
    """The thermal optimum: drives the planned action sequence; ``describe()`` reports the planned and replayed
    cost, the grid and the frontier (the cost as a function of final SOC).

    Options: ``grid_scale`` (every bin divided by it, splits multiplied), ``soc_bin`` (the SOC bin, then not narrowed on
    short or cheap cycles), ``n_u`` (splits), ``soc_final`` (default: the initial SOC) and ``soc_tol``,
    ``on_infeasible`` (``"raise"`` or ``"closest"``), ``frontier_halfwidth`` (final SOCs kept around the target),
    ``plan_cache`` (reuse a plan solved before for the same problem, settings and planner sources), ``threads``,
    ``seed_with`` (teacher strategies whose run of the episode seeds the search, :func:`seed_runs`; default
    ``ecms_thermal``: the thermal optimum is never dearer than it at its final SOC).
    """

    name = "dp_thermal"
    order = 80
    colour = "#7f7f7f"
    line_style = "--"
    leaderboard_label = "dp_thermal (the optimum)"
    optimum = True
    in_benchmark = True
    seconds_per_step = 0.06  # the plan searches: 0.03-0.12
    thermal_aware = True

    def __init__(self, grid_scale: float = 1.0, soc_bin: float | None = None, n_u: int | None = None,
                 soc_final: float | None = None, soc_tol: float = 0.005, on_infeasible: str = "raise",
                 frontier_halfwidth: float = 0.08, plan_cache: bool = True, threads: int | None = None,
                 seed_with: tuple[str, ...] | list[str] = ("ecms_thermal",)):
        if on_infeasible not in ("raise", "closest"):
            raise ValueError(f"{self.name}: on_infeasible {on_infeasible!r} is not one of ['raise', 'closest']")
        if not grid_scale > 0.0:
            raise ValueError(f"{self.name}: grid_scale must be > 0, got {grid_scale}")
        if soc_tol < 0.0 or not frontier_halfwidth > soc_tol:
            raise ValueError(f"{self.name}: need 0 <= soc_tol < frontier_halfwidth, got {soc_tol}, "
                             f"{frontier_halfwidth}")
        if soc_bin is not None and not soc_bin > 0:
            raise ValueError(f"{self.name}: soc_bin must be > 0, got {soc_bin}")
        if n_u is not None and not n_u > 1:
            raise ValueError(f"{self.name}: n_u must be at least 2, got {n_u}")
        if isinstance(seed_with, str):
            seed_with = tuple(name.strip() for name in seed_with.split(",") if name.strip())
        teachers = [cls.name for cls in registered() if cls.teacher]
        for name in seed_with:
            if name not in teachers:
                raise ValueError(f"{self.name}: seed_with {name!r} is not a teacher strategy; teachers: "
                                 f"{', '.join(sorted(teachers))}")
        self.seed_with = tuple(seed_with)
        grid = SearchGrid().scaled(float(grid_scale))
        grid = dataclasses.replace(grid, soc=grid.soc if soc_bin is None else float(soc_bin),
                                   n_u=grid.n_u if n_u is None else int(n_u))
        self.settings = OptimumSettings(grid=grid, fixed_soc_bin=soc_bin is not None, soc_final=soc_final,
                                        soc_tol=float(soc_tol), on_infeasible=on_infeasible,
                                        frontier_halfwidth=float(frontier_halfwidth), threads=threads)
        self.plan_cache = bool(plan_cache)
        self.plan: OptimumPlan | None = None
        self._key, self._k0 = None, 0

    def plan_for(self, problem: DPProblem) -> np.ndarray:
        """Search (or reuse the plan of the same problem) and return the planned action sequence."""
        key = self.settings.key(problem)
        if self.plan is None or key != self._key:
            seeds = seed_runs(self.env, self.seed_with) if self.seed_with else None
            self.plan, self._key = cached_plan(problem, self.settings, self.plan_cache, seeds), key
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
            "state": ["soc", "motor_temp_c", "winding_temp_c", "coolant_temp_c", "heat_x", "motor_cutoff",
                      "winding_trip"],
            "grid": {**dataclasses.asdict(g), "dominance": True, "refine": True, "n_local": N_LOCAL,
                     "local_halfwidth": LOCAL_HALFWIDTH, "first_pass_scale": FIRST_PASS_SCALE,
                     "refine_global_stride": REFINE_STRIDE, "seed_dp": True, "bin_budget": BIN_BUDGET},
            "seed_with": list(self.seed_with), "soc_tol": s.soc_tol, "on_infeasible": s.on_infeasible,
            "frontier_halfwidth": s.frontier_halfwidth, "thermal_planning": "exact state (forward search)",
            **(self.plan.report if self.plan is not None else {}),
        }


def seed_runs(env: Any, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Each teacher strategy's actions over the rest of ``env``'s episode, driven on a copy of the env as it stands (a
    teacher acts from the env's state, not from the observation)."""
    runs = {}
    for name in names:
        e = copy.deepcopy(env.unwrapped if hasattr(env, "unwrapped") else env)
        strategy = strategy_class(name)()
        strategy.reset(e)
        u, done = [], False
        while not done:
            action = np.asarray(strategy.act(None, {}), dtype=np.float32).reshape(1)
            done = e.step(action)[3]
            u.append(float(action[0]))
        runs[name] = np.asarray(u, dtype=np.float32)
    return runs
