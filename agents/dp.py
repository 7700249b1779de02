"""``dp``: dynamic programming over the known cycle with SOC as the state, thermal-blind
(:mod:`hev_thermal_env.planning.soc_dp`: the corridor, the prices, the thermal state held while planning).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from hev_thermal_env.physics import core
from hev_thermal_env.planning.problem import DPProblem, split_grid
from hev_thermal_env.planning.soc_dp import WALL_G_PER_SOC, DPPlan, DPSettings, choose, rollout, solve

from .base import Strategy, register


@register
class DPStrategy(Strategy):
    """Dynamic programming over the known cycle. At each real step it re-optimises one step over a finer u grid (its
    shares of the available regeneration while braking) against the plan's cost-to-go, from the actual state
    (``env.peek``); ``describe()`` records the grid sizes, the solve time and the vehicle-steps evaluated (a coarse DP
    is not an optimum).

    Options: ``n_soc`` SOC grid points across each stage's corridor, ``n_u`` splits over [-1, 1] in the backward pass
    and ``n_u_exec`` when acting (while braking those in [0, 1]), ``soc_final`` (default: the initial SOC) and
    ``soc_tol``, ``on_infeasible`` (``"raise"``: :class:`~hev_thermal_env.planning.problem.DPInfeasibleError`;
    ``"closest"``: plan for the nearest reachable band of the same width), ``price_soc_deviation``, ``threads``.
    """

    name = "dp"
    order = 70
    colour = "#000000"
    line_style = "-"
    label_suffix = " (thermal-blind)"
    optimum = True
    in_benchmark = True
    seconds_per_step = 0.004

    def __init__(self, n_soc: int = DPSettings.n_soc, n_u: int = DPSettings.n_u, n_u_exec: int = DPSettings.n_u_exec,
                 soc_tol: float = DPSettings.soc_tol,
                 soc_final: float | None = None, on_infeasible: str = "raise", price_soc_deviation: bool = False,
                 threads: int | None = None):
        if on_infeasible not in ("raise", "closest"):
            raise ValueError(f"{self.name}: on_infeasible {on_infeasible!r} is not one of ['raise', 'closest']")
        if soc_tol < 0.0:
            raise ValueError(f"{self.name}: soc_tol must be >= 0, got {soc_tol}")
        if min(n_soc, n_u, n_u_exec) < 2:
            raise ValueError(f"{self.name}: n_soc, n_u and n_u_exec must be at least 2")
        self.settings = DPSettings(n_soc=int(n_soc), n_u=int(n_u), n_u_exec=int(n_u_exec), soc_tol=float(soc_tol),
                                   soc_final=soc_final, on_infeasible=on_infeasible,
                                   price_soc_deviation=bool(price_soc_deviation), threads=threads)
        self.plan: DPPlan | None = None
        self.problem: DPProblem | None = None
        self._cache_key, self._report = None, {}
        self._u_exec = split_grid(self.settings.n_u_exec)
        self._shares = self._u_exec >= 0.0  # while braking u < 0 brakes like u = 0

    def plan_for(self, problem: DPProblem) -> DPPlan:
        """Solve (or reuse the last solve for the same cycle, start, vehicle and settings)."""
        key = problem.key() + repr(self.settings)
        if self.plan is not None and key == self._cache_key:
            return self.plan
        t0 = time.perf_counter()
        plan = solve(problem, self.settings)
        run = rollout(plan, problem, self.settings, free=False)
        self._report = {
            "planned_soc_final": float(run["state"][-1, core.SOC]),
            "planned_fuel_g": float(run["out"][:, core.FUEL_G].sum()),
            "planned_cost_g": float(plan.lookup(0, problem.state0[None, :])[0]),
            "plan_total_s": time.perf_counter() - t0,
        }
        self.plan, self._cache_key = plan, key
        return plan

    def reset(self, env: Any) -> None:
        super().reset(env)
        self.problem = DPProblem.from_env(self.env)
        self.plan_for(self.problem)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        env, plan = self.env, self.plan
        i = int(env.k) - plan.k0
        if i < 0 or i >= plan.n_stages:
            return np.zeros(1, dtype=np.float32)
        st, out = env.peek(self._u_exec)
        demand = out[0, core.SHAFT_DEMAND]
        if demand == 0.0:
            return np.zeros(1, dtype=np.float32)  # standing: the action has no effect
        u = self._u_exec
        if demand < 0.0:
            st, out, u = st[self._shares], out[self._shares], u[self._shares]
        j = choose(plan, i, st, out, self.problem, self.settings, u)
        return np.array([u[j]], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        s = self.settings
        d: dict[str, Any] = {
            "name": self.name, "state": ["soc"], "grid": {"soc": s.n_soc}, "n_u": s.n_u, "n_u_exec": s.n_u_exec,
            "soc_tol": s.soc_tol, "on_infeasible": s.on_infeasible, "penalty_g_per_soc": WALL_G_PER_SOC,
            "price_overheat": False, "price_soc_deviation": s.price_soc_deviation,
            "thermal_planning": "held at the initial state",
        }
        if (p := self.plan) is not None:
            d.update({"n_states": p.n_soc, "n_stages": p.n_stages, "solve_s": p.solve_s,
                      "vehicle_steps_evaluated": int(p.n_evals),
                      "vehicle_steps_per_s": p.n_evals / max(p.solve_s, 1e-9), **p.info, **self._report})
        return d
