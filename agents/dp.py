"""Deterministic dynamic programming over a known cycle with SOC as the state: ``dp``, thermal-blind.

The optimum of the SOC-only problem; the yardstick of the benchmark is the thermal optimum
``dp_thermal`` (:mod:`.optimum`), which plans over the whole thermal state. Backward recursion over the stages
k = N−1 … 0 of the cycle on a grid of states; for every stage ONE batched call of the physics
step (:meth:`~hev_thermal_env.physics.PhysicsCore.step`, split over threads) evaluates every grid state ×
every split u (batch = n_states·n_u), so DP sees exactly the physics the environment runs,
including the capped demand and the trace miss. Where the demand is not positive (braking,
coasting, standing) the action has no effect and the stage is evaluated once per grid state.

Cost (grams of fuel equivalent, the env's own reward, :func:`hev_thermal_env.envs.reward.stage_cost_g`):
fuel + missed wheel energy at the reward's miss price + the battery's chemical energy at the
reward's battery price; ``price_overheat`` adds the reward's overheat terms (soft temperature
limit, cutoff, derate weight). ``price_soc_deviation`` adds the reward's SOC terms: the
quadratic deviation per stage, and the band settlement, which adds up to a charge on the final SOC
and is charged there (:func:`hev_thermal_env.envs.reward.soc_band_charge_g`). With the default
weights (1) these are the prices of the corrected-fuel metric, so DP minimises the corrected fuel.

Final-SOC constraint: the final SOC must lie in the band [SOC_final − tol, SOC_final + tol]
(default: SOC_final = the initial SOC, tol = 0.005). The SOC moves far less than a grid cell per
step, so a penalty wall interpolated between fixed grid points diffuses back through the stages
(a smeared wall is charged to paths that run near it). Instead the SOC grid of each stage spans
exactly the corridor of states that are reachable from the start AND can still reach the band:
forward, the SOC after u = +1 (most discharge) and u = −1 (most charge) from the start; backward,
the SOC from which u = −1 / u = +1 just reaches the band's lower / upper edge (solved per stage
by a fixed-point iteration on the physics step). ``n_soc`` points span the corridor at every
stage, so the walls sit on the grid's ends and never get interpolated; beyond the ends the
cost-to-go continues with the slope ``penalty_g_per_soc`` (10⁶ g per unit SOC). If the start is
outside the corridor the band is unreachable and :class:`DPInfeasibleError` says so (with the
reachable final SOC range); ``on_infeasible="closest"`` instead moves the band (same width) to
the nearest reachable final SOC and plans for it.

Cost-to-go between grid points: multilinear interpolation (SOC on the stage's corridor grid, the
other dimensions on fixed uniform grids, clamped at their edges). Execution: at each real step
the strategy re-optimises one step over a (finer) u grid against the cost-to-go: ``env.peek``
evaluates every candidate from the actual state and the cheapest stage cost + interpolated
cost-to-go wins. So the policy is applied at the actual SOC (and heat index, temperature) even
when the real run departs from the plan.

The thermal model: the state is SOC only. The thermal state (temperatures, heat-index integrator,
cutoff) is held at its initial value while planning: the plan is thermal-blind (no heat index
build-up, no cutoff), then executed forward in the real environment with the thermal model on,
where the one-step re-optimisation sees the real derating. Where heat binds (the ``hot`` and
``summer`` scenarios, long climbs) it is not an optimum: the benchmark labels it thermal-blind and
measures every strategy against ``dp_thermal``. The backward solver (:func:`solve`) takes more
state dimensions (``DPSettings.dims``: ``heat_x``, ``temp``) on fixed grids for experiments.

``describe()`` records the grid sizes, the solve time and the number of vehicle-steps evaluated:
a coarse DP is not an optimum.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import soc_band_charge_g
from hev_thermal_env.physics import core as C

from .base import Strategy
from .common import argmin_small_action, default_threads, stage_cost_g
from .dp_corridor import Corridor, corridor
from .dp_grid import (
    DIM_COLUMNS,
    DPInfeasibleError,
    DPPlan,
    DPProblem,
    DPSettings,
    fixed_grids,
    interp_uniform,
)

__all__ = ["DPInfeasibleError", "DPPlan", "DPProblem", "DPSettings", "DPStrategy", "Corridor", "choose", "corridor",
           "rollout", "solve"]


def solve(problem: DPProblem, settings: DPSettings, held: np.ndarray | None = None) -> DPPlan:
    """Backward DP over the cycle; ``held`` [n_stages + 1, N_STATE] gives the non-state columns per stage."""
    t_start = time.perf_counter()
    s = settings
    n_stages = problem.n_stages
    held = _held_columns(problem, s, held)
    cor, info = corridor(problem, s, held)
    soc_lo = cor.lo.copy()
    soc_hi = np.maximum(cor.hi, soc_lo + 1e-9)
    grids = fixed_grids(problem, s)
    shape = tuple(len(g) for g in grids)
    cols = [DIM_COLUMNS[d] for d in s.dims]
    n_soc = shape[0]
    idx_mesh = np.stack([m.ravel() for m in np.meshgrid(*[np.arange(k) for k in shape], indexing="ij")], axis=1)
    n_states = idx_mesh.shape[0]
    u_grid = np.linspace(-1.0, 1.0, s.n_u)
    n_u = s.n_u
    temp_state = "temp" in s.dims
    cutoff_c = problem.core.config.thermal.cutoff_temp_c
    thermal_on = problem.core.config.thermal.enabled
    unit = np.linspace(0.0, 1.0, n_soc)

    # batches reused across stages: rows of state r are r*reps ... (r+1)*reps - 1
    def make_states(reps: int) -> tuple[np.ndarray, np.ndarray]:
        x = np.repeat(held[0][None, :], n_states * reps, axis=0)
        for j in range(1, len(cols)):
            x[:, cols[j]] = np.repeat(grids[j][idx_mesh[:, j]], reps)
        if temp_state:
            x[:, C.CUTOFF] = (x[:, C.TEMP_C] >= cutoff_c) if thermal_on else 0.0
        return x, np.repeat(unit[idx_mesh[:, 0]], reps)

    (x_big, frac_big), (x_small, frac_small) = make_states(n_u), make_states(1)
    a_big, a_small = np.tile(u_grid, n_states), np.zeros(n_states)
    so_big, so_small = np.empty_like(x_big), np.empty_like(x_small)
    out_big, out_small = np.empty((x_big.shape[0], C.N_OUT)), np.empty((n_states, C.N_OUT))
    cond_big = np.repeat(problem.cond[None, :], x_big.shape[0], axis=0)
    cond_small = cond_big[:n_states]
    jn_big, jn_small = np.empty(x_big.shape[0]), np.empty(n_states)
    held_cols = [c for c in range(C.N_STATE) if c not in cols and not (temp_state and c == C.CUTOFF)]
    held_varies = bool(np.any(held[1:, held_cols] != held[:-1, held_cols]))

    n_arr = np.array(shape, dtype=np.int64)
    cols_arr = np.array(cols, dtype=np.int64)
    lo = np.array([0.0] + [g[0] for g in grids[1:]])
    step = np.array([1.0] + [g[1] - g[0] for g in grids[1:]])
    J = np.empty((n_stages + 1, n_states))
    J[n_stages] = 0.0  # the last stage's grid lies inside the band
    if s.price_soc_deviation:  # the reward's band settlement adds up to a charge on the final SOC: paid there
        final_soc = soc_lo[-1] + unit[idx_mesh[:, 0]] * (soc_hi[-1] - soc_lo[-1])
        J[n_stages] = soc_band_charge_g(problem.reward_params, final_soc, problem.soc_target)
    active = problem.demand_positive()
    n_evals = 0
    threads = default_threads() if s.threads is None else s.threads

    for i in range(n_stages - 1, -1, -1):
        if active[i]:
            x, a, so, out, cond, jn, frac, reps = x_big, a_big, so_big, out_big, cond_big, jn_big, frac_big, n_u
        else:
            x, a, so, out, cond, jn, frac, reps = (x_small, a_small, so_small, out_small, cond_small, jn_small,
                                                   frac_small, 1)
        x[:, C.SOC] = soc_lo[i] + frac * (soc_hi[i] - soc_lo[i])
        if held_varies:
            for c in held_cols:
                x[:, c] = held[i, c]
        v0, v1, g = problem.stage_inputs(i, x.shape[0])
        problem.core.step(x, a, v0, v1, g, cond, state_out=so, out=out, threads=threads)
        n_evals += x.shape[0]
        cost = stage_cost_g(problem.reward_params, out, so, problem.soc_target, problem.lhv, problem.core.dt_s,
                            soc_deviation=s.price_soc_deviation, overheat=s.price_overheat, soc_band=False)
        lo[0] = soc_lo[i + 1]
        step[0] = (soc_hi[i + 1] - soc_lo[i + 1]) / (n_soc - 1)
        interp_uniform(J[i + 1], lo, step, n_arr, so, cols_arr, s.penalty_g_per_soc, jn)
        J[i] = (cost + jn).reshape(n_states, reps).min(axis=1)

    plan = DPPlan(dims=tuple(s.dims), grids=grids, soc_lo=soc_lo, soc_hi=soc_hi, cost_to_go=J, k0=problem.k0,
                  held=held, soc_final=0.5 * (cor.band[0] + cor.band[1]), soc_tol=0.5 * (cor.band[1] - cor.band[0]),
                  wall_g_per_soc=s.penalty_g_per_soc, solve_s=time.perf_counter() - t_start, n_evals=n_evals)
    plan.info.update(info)
    plan.info["threads"] = threads
    plan.info["corridor_max_width"] = float(np.max(soc_hi - soc_lo))
    return plan


def _held_columns(problem: DPProblem, s: DPSettings, held: np.ndarray | None) -> np.ndarray:
    """Check the problem and settings; the held (non-state) columns per stage, default the start state's."""
    if problem.n_stages < 1:
        raise ValueError("dp: the cycle has no step left to plan")
    if s.dims[0] != "soc":
        raise ValueError("dp: the first state dimension must be 'soc'")
    return np.repeat(problem.state0[None, :], problem.n_stages + 1, axis=0) if held is None else held


def choose(plan: DPPlan, stage: int, state_after: np.ndarray, out: np.ndarray, problem: DPProblem,
           settings: DPSettings, actions: np.ndarray) -> int:
    """Index of the cheapest candidate: stage cost + interpolated cost-to-go of its next state."""
    cost = stage_cost_g(problem.reward_params, out, state_after, problem.soc_target, problem.lhv,
                        problem.core.dt_s, soc_deviation=settings.price_soc_deviation,
                        overheat=settings.price_overheat, soc_band=False)
    return argmin_small_action(cost + plan.lookup(stage + 1, state_after), actions)


def rollout(plan: DPPlan, problem: DPProblem, settings: DPSettings, *, free: bool) -> dict[str, np.ndarray]:
    """Run the plan forward on the physics from the start state, re-optimising each step.

    ``free=False`` holds the non-state columns at the plan's values (the planning model: the plan's
    own prediction, reported by ``describe()``); ``free=True`` lets the whole state evolve (as the
    environment would; used to get the temperature trace in ``temp_mode="trajectory"``).
    """
    u_exec = np.linspace(-1.0, 1.0, settings.n_u_exec)
    n = plan.n_stages
    st = problem.state0.copy()
    cols = [DIM_COLUMNS[d] for d in plan.dims]
    states = np.empty((n + 1, C.N_STATE))
    outs = np.empty((n, C.N_OUT))
    us = np.empty(n)
    states[0] = st
    m = len(u_exec)
    idle = int(np.argmin(np.abs(u_exec)))  # the action has no effect: report u = 0
    cond = np.repeat(problem.cond[None, :], m, axis=0)
    so = np.empty((m, C.N_STATE))
    out = np.empty((m, C.N_OUT))
    for i in range(n):
        x = np.repeat(st[None, :], m, axis=0)
        v0, v1, g = problem.stage_inputs(i, m)
        problem.core.step(x, u_exec, v0, v1, g, cond, state_out=so, out=out)
        j = choose(plan, i, so, out, problem, settings, u_exec) if out[0, C.SHAFT_DEMAND] > 0.0 else idle
        st = so[j].copy()
        if not free:
            keep = st[cols].copy()
            st[:] = plan.held[i + 1]
            st[cols] = keep
            if "temp" in plan.dims:
                st[C.CUTOFF] = so[j, C.CUTOFF]
        states[i + 1] = st
        outs[i] = out[j]
        us[i] = u_exec[j]
    return {"state": states, "out": outs, "u": us}


class DPStrategy(Strategy):
    """Dynamic programming over the known cycle (SOC state; thermal state held while planning).

    Options: ``n_soc`` SOC grid points across each stage's corridor, ``n_u`` splits in the
    backward pass and ``n_u_exec`` when acting, ``soc_final`` (default: the initial SOC) and
    ``soc_tol``, ``on_infeasible`` (``"raise"``: :class:`DPInfeasibleError`; ``"closest"``: plan for
    the nearest reachable band of the same width), ``penalty_g_per_soc``, ``price_overheat``,
    ``price_soc_deviation``, ``threads``.
    """

    name = "dp"
    thermal_aware = False
    default_dims: tuple[str, ...] = ("soc",)

    def __init__(self, n_soc: int = 401, n_u: int = 41, n_u_exec: int = 101, soc_tol: float = 0.005,
                 soc_final: float | None = None, on_infeasible: str = "raise", penalty_g_per_soc: float = 1e6,
                 price_overheat: bool = False, price_soc_deviation: bool = False, threads: int | None = None,
                 **extra: Any):
        if extra:
            raise ValueError(f"{self.name}: unknown option(s) {sorted(extra)}")
        if on_infeasible not in ("raise", "closest"):
            raise ValueError(f"{self.name}: on_infeasible {on_infeasible!r} is not one of ['raise', 'closest']")
        if soc_tol < 0.0:
            raise ValueError(f"{self.name}: soc_tol must be >= 0, got {soc_tol}")
        if min(n_soc, n_u, n_u_exec) < 2:
            raise ValueError(f"{self.name}: n_soc, n_u and n_u_exec must be at least 2")
        self.settings = DPSettings(dims=self.default_dims, n_soc=int(n_soc), n_u=int(n_u), n_u_exec=int(n_u_exec),
                                   soc_tol=float(soc_tol), soc_final=soc_final, on_infeasible=on_infeasible,
                                   penalty_g_per_soc=float(penalty_g_per_soc), price_overheat=bool(price_overheat),
                                   price_soc_deviation=bool(price_soc_deviation), threads=threads)
        self.plan: DPPlan | None = None
        self.problem: DPProblem | None = None
        self._used = self.settings
        self._cache_key: str | None = None
        self._report: dict[str, Any] = {}
        self._u_exec = np.linspace(-1.0, 1.0, self.settings.n_u_exec)

    # -- planning -------------------------------------------------------------------------------
    def _settings_key(self) -> str:
        return repr(self.settings)

    def plan_for(self, problem: DPProblem) -> DPPlan:
        """Solve (or reuse the last solve for the same cycle, start, vehicle and settings)."""
        key = problem.key() + self._settings_key()
        if self.plan is not None and key == self._cache_key:
            return self.plan
        t0 = time.perf_counter()
        settings = dataclasses.replace(self.settings)
        plan = self._solve(problem, settings)
        run = rollout(plan, problem, settings, free=False)
        self._report = {
            "planned_soc_final": float(run["state"][-1, C.SOC]),
            "planned_fuel_g": float(run["out"][:, C.FUEL_G].sum()),
            "planned_cost_g": float(plan.lookup(0, problem.state0[None, :])[0]),
            "plan_total_s": time.perf_counter() - t0,
        }
        self.plan, self._cache_key, self._used = plan, key, settings
        return plan

    def _solve(self, problem: DPProblem, settings: DPSettings) -> DPPlan:
        return solve(problem, settings)

    def reset(self, env: Any) -> None:
        super().reset(env)
        self.problem = DPProblem.from_env(self.env)
        self.plan_for(self.problem)

    # -- acting ---------------------------------------------------------------------------------
    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        env, plan = self.env, self.plan
        i = int(env.k) - plan.k0
        if i < 0 or i >= plan.n_stages:
            return np.zeros(1, dtype=np.float32)
        st, out = env.peek(self._u_exec)
        if out[0, C.SHAFT_DEMAND] <= 0.0:
            return np.zeros(1, dtype=np.float32)  # braking or standing: the action has no effect
        j = choose(plan, i, st, out, self.problem, self._used, self._u_exec)
        return np.array([self._u_exec[j]], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        s = self._used
        d: dict[str, Any] = {
            "name": self.name, "state": list(s.dims),
            "grid": {dim: s.sizes()[dim] for dim in s.dims}, "n_u": s.n_u, "n_u_exec": s.n_u_exec,
            "soc_tol": s.soc_tol, "on_infeasible": s.on_infeasible, "penalty_g_per_soc": s.penalty_g_per_soc,
            "price_overheat": s.price_overheat, "price_soc_deviation": s.price_soc_deviation,
            "thermal_planning": "held at the initial state" if "heat_x" not in s.dims else "DP state",
        }
        if self.plan is not None:
            p = self.plan
            d.update({
                "grid_ranges": {dim: [float(g[0]), float(g[-1])] for dim, g in zip(p.dims[1:], p.grids[1:])},
                "n_states": int(np.prod(p.shape)), "n_stages": p.n_stages, "solve_s": p.solve_s,
                "vehicle_steps_evaluated": int(p.n_evals), "vehicle_steps_per_s": p.n_evals / max(p.solve_s, 1e-9),
                **p.info, **self._report})
        return d
