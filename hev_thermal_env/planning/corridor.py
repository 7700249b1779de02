"""The reachable SOC corridor of dynamic programming: forward and backward envelopes of the SOC.

Each stage's SOC grid spans only the SOCs that are reachable from the start and from which the final-SOC band is still
reachable (:func:`corridor`), so the grid's resolution goes where paths can be and the final-SOC constraint is exact
instead of a smeared penalty wall. Forward, the SOC after the most discharge and the most charge the action allows
(:func:`extreme_actions`) from the start; backward, the SOC from which the most charge / discharge just reaches the
band's lower / upper edge (solved per stage by a fixed-point iteration on the physics step).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.physics import core

from .problem import BRAKING, TRACTION, DPInfeasibleError, DPProblem


def extreme_actions(problem: DPProblem) -> np.ndarray:
    """Per stage [n_stages, 2], the action of the most discharge and of the most charge: in traction u = +1 (the motor
    asked for the whole demand) and u = −1 (the engine up to twice the demand or its full load); while braking u = 0
    (no regeneration, the spinning motor's loss drawn from the battery) and u = 1 (all the available regeneration)."""
    kind = problem.stage_kinds()
    discharge = np.where(kind == TRACTION, 1.0, 0.0)
    charge = np.where(kind == TRACTION, -1.0, np.where(kind == BRAKING, 1.0, 0.0))
    return np.column_stack([discharge, charge])


def forward_envelope(problem: DPProblem, held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest SOC reachable at each stage from the start: the most discharge and the most charge
    throughout (:func:`extreme_actions`). The other state columns follow ``held`` (the planning model)."""
    n = problem.n_stages
    st = np.repeat(problem.state0[None, :], 2, axis=0)
    a = extreme_actions(problem)
    lo = np.empty(n + 1)
    hi = np.empty(n + 1)
    lo[0] = hi[0] = problem.state0[core.SOC]
    for i in range(n):
        st[:] = held[i]
        st[0, core.SOC], st[1, core.SOC] = lo[i], hi[i]
        so, _ = problem.step(st, a[i], i)
        lo[i + 1], hi[i + 1] = so[0, core.SOC], so[1, core.SOC]
    return lo, hi


def backward_envelope(problem: DPProblem, held: np.ndarray, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Lowest / highest SOC at each stage from which the most charge / the most discharge throughout
    (:func:`extreme_actions`) still reaches the band (three fixed-point iterations per stage)."""
    n = problem.n_stages
    bat = problem.core.config.battery
    lo = np.empty(n + 1)
    hi = np.empty(n + 1)
    lo[n], hi[n] = band
    st = np.empty((2, core.N_STATE))
    a = extreme_actions(problem)[:, ::-1].copy()  # row 0 charges (towards the lower edge), row 1 discharges
    for i in range(n - 1, -1, -1):
        target = np.array([lo[i + 1], hi[i + 1]])
        guess = target.copy()
        for _ in range(3):
            st[:] = held[i]
            st[:, core.SOC] = np.clip(guess, bat.soc_min, bat.soc_max)
            so, _ = problem.step(st, a[i], i)
            guess = target - (so[:, core.SOC] - st[:, core.SOC])
        lo[i] = bat.soc_min if target[0] <= bat.soc_min + 1e-12 else min(max(guess[0], bat.soc_min), bat.soc_max)
        hi[i] = bat.soc_max if target[1] >= bat.soc_max - 1e-12 else min(max(guess[1], bat.soc_min), bat.soc_max)
    return lo, hi


def corridor(problem: DPProblem, held: np.ndarray, soc_final: float | None, tol: float,
             on_infeasible: str) -> tuple[np.ndarray, np.ndarray, dict]:
    """The SOC corridor (lowest and highest SOC per stage: reachable from the start and still reaching the band)
    for the band ``soc_final`` ± ``tol`` (default: the initial SOC), or for the nearest reachable one
    (``on_infeasible="closest"``)."""
    soc0 = float(problem.state0[core.SOC])
    target = soc0 if soc_final is None else float(soc_final)
    band = (target - tol, target + tol)
    f_lo, f_hi = forward_envelope(problem, held)
    info: dict[str, Any] = {"soc_final_requested": target, "reachable_final_soc": [float(f_lo[-1]), float(f_hi[-1])]}

    def bounds(band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, bool]:
        b_lo, b_hi = backward_envelope(problem, held, band)
        lo, hi = np.maximum(f_lo, b_lo), np.minimum(f_hi, b_hi)
        return lo, hi, bool(np.all(lo <= hi + 1e-9))

    lo, hi, feasible = bounds(band)
    info["final_soc_feasible"] = feasible
    if not feasible:
        if on_infeasible == "raise":
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
