"""Dynamic programming over a known cycle with SOC as the state (the ``dp`` strategy's planner), and its corridor.

Backward recursion over the stages on a grid of SOC states, the thermal state held at its initial value: thermal-blind,
so where heat binds not an optimum (the yardstick is :mod:`.thermal_optimum`). Each stage is ONE batched call of the
physics step for every grid state × every split the stage offers (:func:`~.problem.stage_splits`). Cost (g of fuel
equivalent, the env's reward, :func:`~hev_thermal_env.envs.reward.stage_cost_g`): fuel, missed wheel energy and
battery energy at the reward's prices; ``price_soc_deviation`` adds the SOC terms (the band settlement charged on the
final SOC, :func:`~hev_thermal_env.envs.reward.soc_band_charge_g`).

The final SOC lies within ``soc_tol`` of ``soc_final`` (default: the initial SOC ± 0.005). A penalty wall between fixed
grid points would diffuse back through the stages (the SOC moves far less than a cell per step), so each stage's
``n_soc`` points span exactly its corridor (:func:`corridor`: reachable from the start and still reaching the band),
and beyond the grid's ends the cost-to-go continues with the slope :data:`WALL_G_PER_SOC`. At each real step
:func:`choose` picks among a finer u grid from the actual state, by stage cost plus interpolated cost-to-go.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import soc_band_charge_g, stage_cost_g
from hev_thermal_env.physics import core
from hev_thermal_env.physics.jit import jit

from .problem import IDLE, DPInfeasibleError, DPProblem, argmin_small_action, default_threads, split_grid, stage_splits

#: Beyond the corridor's ends the cost-to-go continues with this slope (g per unit SOC).
WALL_G_PER_SOC = 1e6


@jit
def interp_soc(values, lo, step, n, soc, wall, result):
    """Linear interpolation of ``values`` (``n`` points from ``lo``, spacing ``step``) at every ``soc[b]``, continued
    beyond the grid's ends with slope ``wall`` (value at the end + wall × distance)."""
    top = n - 1.0
    for b in range(soc.shape[0]):
        excess = 0.0
        f = (soc[b] - lo) / step
        if f < 0.0:
            excess = (0.0 - f) * step
            f = 0.0
        elif f > top:
            excess = (f - top) * step
            f = top
        i = min(int(f), n - 2)
        w = f - i
        acc = 0.0
        if 1.0 - w != 0.0:
            acc += (1.0 - w) * values[i]
        if w != 0.0:
            acc += w * values[i + 1]
        result[b] = acc + wall * excess


@dataclass
class DPSettings:
    """Grid and pricing options of a DP solve (see the module docstring)."""

    n_soc: int = 151
    n_u: int = 15
    n_u_exec: int = 101
    soc_final: float | None = None  # default: the initial SOC
    soc_tol: float = 0.005
    on_infeasible: str = "raise"
    price_soc_deviation: bool = False
    threads: int | None = None


@dataclass
class DPPlan:
    """A solved DP: the cost-to-go on the SOC grid of every stage (stage i: ``n_soc`` points from ``soc_lo[i]`` to
    ``soc_hi[i]``, the corridor), and how it was made."""

    soc_lo: np.ndarray  # [n_stages + 1]
    soc_hi: np.ndarray  # [n_stages + 1]
    cost_to_go: np.ndarray  # [n_stages + 1, n_soc]
    k0: int
    solve_s: float
    n_evals: int
    info: dict = field(default_factory=dict)

    @property
    def n_stages(self) -> int:
        return self.cost_to_go.shape[0] - 1

    @property
    def n_soc(self) -> int:
        return self.cost_to_go.shape[1]

    def lookup(self, stage: int, states: np.ndarray) -> np.ndarray:
        """Cost-to-go at ``stage`` (0 = plan start) of full states [B, N_STATE]."""
        res = np.empty(states.shape[0])
        lo, hi = self.soc_lo[stage], self.soc_hi[stage]
        interp_soc(self.cost_to_go[stage], lo, (hi - lo) / (self.n_soc - 1), self.n_soc, states[:, core.SOC],
                   WALL_G_PER_SOC, res)
        return res


class _Batch:
    """Every SOC grid point × ``u.size`` splits (row r·reps + j: point r, split u[j]), reused across stages."""

    def __init__(self, problem: DPProblem, unit: np.ndarray, u: np.ndarray):
        n = unit.size * u.size
        self.reps = u.size
        self.x = np.repeat(problem.state0[None, :], n, axis=0)
        self.frac = np.repeat(unit, u.size)
        self.a = np.tile(u, unit.size)
        self.so, self.out = np.empty_like(self.x), np.empty((n, core.N_OUT))
        self.cond = np.repeat(problem.cond[None, :], n, axis=0)
        self.jn = np.empty(n)


def _backward(problem: DPProblem, s: DPSettings, soc_lo: np.ndarray, soc_hi: np.ndarray,
              threads: int) -> tuple[np.ndarray, int]:
    """The cost-to-go [n_stages + 1, n_soc] on the corridor grids, and the vehicle-steps evaluated."""
    n_stages, n_soc = problem.n_stages, s.n_soc
    unit = np.linspace(0.0, 1.0, n_soc)
    kinds = problem.stage_kinds()
    u = split_grid(s.n_u)
    batches = {k: _Batch(problem, unit, stage_splits(k, u)) for k in np.unique(kinds).tolist()}
    J = np.empty((n_stages + 1, n_soc))
    J[n_stages] = 0.0  # the last stage's grid lies inside the band
    if s.price_soc_deviation:  # the reward's band settlement adds up to a charge on the final SOC: paid there
        final_soc = soc_lo[-1] + unit * (soc_hi[-1] - soc_lo[-1])
        J[n_stages] = soc_band_charge_g(problem.reward_params, final_soc, problem.soc_target)
    n_evals = 0
    for i in range(n_stages - 1, -1, -1):
        b = batches[int(kinds[i])]
        b.x[:, core.SOC] = soc_lo[i] + b.frac * (soc_hi[i] - soc_lo[i])
        v0, v1, g = problem.stage_inputs(i, b.x.shape[0])
        problem.core.step(b.x, b.a, v0, v1, g, b.cond, state_out=b.so, out=b.out, threads=threads)
        n_evals += b.x.shape[0]
        cost = stage_cost_g(problem.reward_params, b.out, b.so, problem.soc_target, problem.lhv, problem.core.dt_s,
                            soc_deviation=s.price_soc_deviation, soc_band=False)
        lo = soc_lo[i + 1]
        interp_soc(J[i + 1], lo, (soc_hi[i + 1] - lo) / (n_soc - 1), n_soc, b.so[:, core.SOC], WALL_G_PER_SOC, b.jn)
        J[i] = (cost + b.jn).reshape(n_soc, b.reps).min(axis=1)
    return J, n_evals


def solve(problem: DPProblem, settings: DPSettings) -> DPPlan:
    """Backward DP over the cycle, the thermal state held at the start's (see the module docstring)."""
    t_start = time.perf_counter()
    if problem.n_stages < 1:
        raise ValueError("dp: the cycle has no step left to plan")
    soc_lo, soc_hi, info = corridor(problem, settings)
    soc_hi = np.maximum(soc_hi, soc_lo + 1e-9)
    threads = default_threads() if settings.threads is None else settings.threads
    J, n_evals = _backward(problem, settings, soc_lo, soc_hi, threads)
    return DPPlan(soc_lo=soc_lo, soc_hi=soc_hi, cost_to_go=J, k0=problem.k0, solve_s=time.perf_counter() - t_start,
                  n_evals=n_evals,
                  info={**info, "threads": threads, "corridor_max_width": float(np.max(soc_hi - soc_lo))})


def choose(plan: DPPlan, stage: int, state_after: np.ndarray, out: np.ndarray, problem: DPProblem,
           settings: DPSettings, actions: np.ndarray) -> int:
    """Index of the cheapest candidate: stage cost + interpolated cost-to-go of its next state."""
    cost = stage_cost_g(problem.reward_params, out, state_after, problem.soc_target, problem.lhv, problem.core.dt_s,
                        soc_deviation=settings.price_soc_deviation, soc_band=False)
    return argmin_small_action(cost + plan.lookup(stage + 1, state_after), actions,
                               engine_off_from=problem.core.config.powertrain.engine_off_from)


def rollout(plan: DPPlan, problem: DPProblem, settings: DPSettings, *, free: bool) -> dict[str, np.ndarray]:
    """Run the plan forward on the physics from the start state, re-optimising each step: ``free=False`` holds the
    thermal state at the start's (the planning model: the plan's own prediction, reported by the ``dp`` strategy),
    ``free=True`` lets the whole state evolve (as the environment would)."""
    u_exec = split_grid(settings.n_u_exec)
    n = plan.n_stages
    st = problem.state0.copy()
    states = np.empty((n + 1, core.N_STATE))
    outs = np.empty((n, core.N_OUT))
    us = np.empty(n)
    states[0] = st
    kinds = problem.stage_kinds()
    for i in range(n):
        cand = stage_splits(int(kinds[i]), u_exec)
        so, out = problem.step(np.repeat(st[None, :], cand.size, axis=0), cand, i)
        j = 0 if kinds[i] == IDLE else choose(plan, i, so, out, problem, settings, cand)
        st = so[j].copy()
        if not free:  # the thermal state held at the start's
            soc = st[core.SOC]
            st[:] = problem.state0
            st[core.SOC] = soc
        states[i + 1] = st
        outs[i] = out[j]
        us[i] = cand[j]
    return {"state": states, "out": outs, "u": us}


def forward_envelope(problem: DPProblem, held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest SOC reachable at each stage from the start: the most discharge and the most charge
    throughout (:meth:`~.problem.DPProblem.extreme_actions`), the other state columns held at ``held`` [N_STATE]."""
    n = problem.n_stages
    st = np.repeat(held[None, :], 2, axis=0)
    a = problem.extreme_actions()
    lo, hi = np.empty(n + 1), np.empty(n + 1)
    lo[0] = hi[0] = problem.state0[core.SOC]
    for i in range(n):
        st[0, core.SOC], st[1, core.SOC] = lo[i], hi[i]
        so, _ = problem.step(st, a[i], i)
        lo[i + 1], hi[i + 1] = so[0, core.SOC], so[1, core.SOC]
    return lo, hi


def backward_envelope(problem: DPProblem, held: np.ndarray, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Lowest / highest SOC at each stage from which the most charge / the most discharge throughout
    (:meth:`~.problem.DPProblem.extreme_actions`) still reaches the band (three fixed-point iterations per stage), the
    other state columns held at ``held`` [N_STATE]."""
    n = problem.n_stages
    bat = problem.core.config.battery
    lo, hi = np.empty(n + 1), np.empty(n + 1)
    lo[n], hi[n] = band
    st = np.repeat(held[None, :], 2, axis=0)
    a = problem.extreme_actions()[:, ::-1].copy()  # row 0 charges (towards the lower edge), row 1 discharges
    for i in range(n - 1, -1, -1):
        target = np.array([lo[i + 1], hi[i + 1]])
        guess = target.copy()
        for _ in range(3):
            st[:, core.SOC] = np.clip(guess, bat.soc_min, bat.soc_max)
            so, _ = problem.step(st, a[i], i)
            guess = target - (so[:, core.SOC] - st[:, core.SOC])
        lo[i] = bat.soc_min if target[0] <= bat.soc_min + 1e-12 else min(max(guess[0], bat.soc_min), bat.soc_max)
        hi[i] = bat.soc_max if target[1] >= bat.soc_max - 1e-12 else min(max(guess[1], bat.soc_min), bat.soc_max)
    return lo, hi


def corridor(problem: DPProblem, s: DPSettings) -> tuple[np.ndarray, np.ndarray, dict]:
    """The SOC corridor (lowest and highest SOC per stage, the thermal state held at the start's: reachable from the
    start and still reaching the band) for the band ``s.soc_final`` ± ``s.soc_tol`` (default: the initial SOC), or for
    the nearest reachable one (``s.on_infeasible="closest"``)."""
    soc0, tol = float(problem.state0[core.SOC]), s.soc_tol
    target = soc0 if s.soc_final is None else float(s.soc_final)
    band = (target - tol, target + tol)
    f_lo, f_hi = forward_envelope(problem, problem.state0)
    info: dict[str, Any] = {"soc_final_requested": target, "reachable_final_soc": [float(f_lo[-1]), float(f_hi[-1])]}

    def bounds(band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, bool]:
        b_lo, b_hi = backward_envelope(problem, problem.state0, band)
        lo, hi = np.maximum(f_lo, b_lo), np.minimum(f_hi, b_hi)
        return lo, hi, bool(np.all(lo <= hi + 1e-9))

    lo, hi, feasible = bounds(band)
    info["final_soc_feasible"] = feasible
    if not feasible:
        if s.on_infeasible == "raise":
            raise DPInfeasibleError(
                f"dp: no feasible path to the final SOC {target:.4f} ± {tol} on cycle {problem.name!r} from SOC "
                f"{soc0:.4f}: the reachable final SOC is [{f_lo[-1]:.4f}, {f_hi[-1]:.4f}] (change soc_final or "
                f"soc_tol, or pass on_infeasible='closest' (evaluate.py run: --dp-on-infeasible closest) to plan for "
                f"the nearest reachable band)")
        if f_hi[-1] < band[0]:
            band = (float(f_hi[-1]) - 2.0 * tol, float(f_hi[-1]))
        else:
            band = (float(f_lo[-1]), float(f_lo[-1]) + 2.0 * tol)
        lo, hi, feasible = bounds(band)
        if not feasible:
            raise DPInfeasibleError(f"dp: even the nearest reachable final-SOC band {band} is infeasible on cycle "
                                    f"{problem.name!r}")
    info["soc_band_used"] = [float(band[0]), float(band[1])]
    return lo, hi, info
