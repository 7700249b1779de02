"""Helpers shared by the model-based strategies (rule, ECMS, DP): batched physics calls and prices.

Every candidate action is evaluated by the one physics step, ``hev_thermal_env.physics.core.step_kernel``,
on a batch. :func:`kernel_step` calls it, split over threads when the compiled kernel releases the
GIL (``nogil``); otherwise in one call.

Prices follow :mod:`hev_thermal_env.reward` exactly (:func:`stage_cost_g` fuses the terms of
:func:`~hev_thermal_env.reward.reward_terms` into one compiled pass; a test checks that the two
agree), so DP, ECMS and the environment's reward value the
same outcomes the same way: fuel, the fuel equivalent of the battery's chemical energy, missed
wheel energy at the miss weight, and (optionally) the overheat terms.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.jit import jit
from hev_thermal_env.physics.simulate import battery_price_g_per_j, miss_price_g_per_j
from hev_thermal_env.reward import RewardParams, reward_terms

#: Batches smaller than this are not split over threads (thread start-up would dominate).
MIN_THREAD_BATCH = 4096

_POOLS: dict[int, ThreadPoolExecutor] = {}


def kernel_releases_gil() -> bool:
    """Whether the compiled physics kernel releases the GIL, so that threads run it in parallel."""
    return bool(getattr(C.step_kernel, "targetoptions", {}).get("nogil", False))


def default_threads() -> int:
    return max(1, min(os.cpu_count() or 1, 8))


def _pool(n: int) -> ThreadPoolExecutor:
    if n not in _POOLS:
        _POOLS[n] = ThreadPoolExecutor(max_workers=n, thread_name_prefix="hev-kernel")
    return _POOLS[n]


def kernel_step(core: C.PhysicsCore, state: np.ndarray, action: np.ndarray, v0: np.ndarray, v1: np.ndarray,
                grade: np.ndarray, cond: np.ndarray, state_out: np.ndarray, out: np.ndarray,
                threads: int | None = None, force_split: bool = False) -> None:
    """``step_kernel`` on a batch, in ``threads`` slices when the kernel releases the GIL.

    ``force_split`` slices the batch even if it does not (a test of the slicing).
    """
    b = state.shape[0]
    n = default_threads() if threads is None else max(1, int(threads))
    if n == 1 or b < MIN_THREAD_BATCH or not (kernel_releases_gil() or force_split):
        C.step_kernel(*core.params, state, action, v0, v1, grade, cond, core.dt_s, state_out, out)
        return
    edges = np.linspace(0, b, n + 1).astype(int)

    def run(j: int) -> None:
        s = slice(edges[j], edges[j + 1])
        C.step_kernel(*core.params, state[s], action[s], v0[s], v1[s], grade[s], cond[s], core.dt_s, state_out[s],
                      out[s])

    list(_pool(n).map(run, range(n)))


#: The equivalence factor (s in fuel + s·E_batt/Q_lhv) that matches the reward's battery price.
REWARD_EQUIVALENCE_FACTOR = battery_price_g_per_j(1.0)  # the price per joule times Q_lhv


def _cost_weights(params: RewardParams, battery: bool, soc_deviation: bool, overheat: bool) -> np.ndarray:
    return np.array([
        params.fuel_weight, params.miss_weight, params.soc_energy_weight if battery else 0.0,
        params.soc_deviation_weight if soc_deviation else 0.0,
        params.overheat_temp_weight if overheat else 0.0, params.overheat_soft_limit_c,
        params.cutoff_weight if overheat else 0.0, params.derate_weight if overheat else 0.0])


@jit
def _stage_cost(w, out, st, soc_target, batt_g_per_j, miss_g_per_j, dt_s, result):
    # the terms of hev_thermal_env.reward.reward_terms, fused (tests/test_dp.py checks equality)
    for b in range(out.shape[0]):
        c = w[0] * out[b, C.FUEL_G] + w[1] * out[b, C.MISSED_J] * miss_g_per_j
        c += w[2] * out[b, C.BATT_CHEM] * dt_s * batt_g_per_j
        if w[3] != 0.0:
            e = (st[b, C.SOC] - soc_target) / 0.1
            c += w[3] * e * e
        if w[4] != 0.0 or w[6] != 0.0 or w[7] != 0.0:
            over = max(st[b, C.TEMP_C] - w[5], 0.0)
            c += w[4] * over * over + w[6] * st[b, C.CUTOFF] + w[7] * min(max(st[b, C.HEAT_X], 0.0), 1.0)
        result[b] = c


def stage_cost_g(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: float,
                 lhv_j_per_g: float, dt_s: float, *, battery: bool = True, soc_deviation: bool = False,
                 overheat: bool = False) -> np.ndarray:
    """Cost in fuel-equivalent grams of each row of a batch step, as the reward prices it.

    Always fuel and missed wheel energy (−(``reward_fuel + reward_miss``)); with ``battery`` the fuel
    equivalent of the battery's chemical energy (the energy part of ``reward_soc``); with
    ``soc_deviation`` the quadratic SOC-deviation part; with ``overheat`` ``reward_overheat``.
    Computed in one compiled pass over the batch; equal to the same terms of
    :func:`hev_thermal_env.reward.reward_terms` (see :func:`stage_cost_reference_g`).
    """
    result = np.empty(out.shape[0])
    _stage_cost(_cost_weights(params, battery, soc_deviation, overheat), out, state_after, float(soc_target),
                battery_price_g_per_j(lhv_j_per_g), miss_price_g_per_j(lhv_j_per_g), float(dt_s), result)
    return result


def stage_cost_reference_g(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: float,
                           lhv_j_per_g: float, dt_s: float, *, battery: bool = True, soc_deviation: bool = False,
                           overheat: bool = False) -> np.ndarray:
    """:func:`stage_cost_g` computed through :func:`~hev_thermal_env.reward.reward_terms` itself."""
    if not soc_deviation:
        params = params.replace(soc_deviation_weight=0.0)
    if not battery:
        params = params.replace(soc_energy_weight=0.0)
    r = reward_terms(params, out, state_after, soc_target, lhv_j_per_g, dt_s)
    total = r["reward_fuel"] + r["reward_miss"] + r["reward_soc"]
    if overheat:
        total = total + r["reward_overheat"]
    return -total


def next_step_demand(env: Any) -> tuple[np.ndarray, np.ndarray]:
    """Peek the next step with u = 0: (state_out [1, N_STATE], out [1, N_OUT]).

    The shaft demand, gear and engine speed of the next step do not depend on the action.
    """
    return env.peek(np.zeros(1))


def argmin_small_action(cost: np.ndarray, actions: np.ndarray, tol_g: float = 1e-9) -> int:
    """Index of the cheapest candidate; among equally cheap ones (e.g. the motor cut off) the smallest |u|."""
    best = float(np.min(cost))
    ties = np.flatnonzero(cost <= best + tol_g)
    if ties.size == 1:
        return int(ties[0])
    return int(ties[np.argmin(np.abs(actions[ties]))])
