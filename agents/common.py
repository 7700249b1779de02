"""Helpers shared by the model-based strategies (rule, ECMS, DP): batched physics calls and prices.

Every candidate action is evaluated by the one physics step, ``hev_thermal_env.physics.core.step_kernel``,
on a batch. :func:`kernel_step` calls it, split over threads when the compiled kernel releases the
GIL (``nogil``); otherwise in one call.

Prices follow :mod:`hev_thermal_env.reward` exactly (:func:`stage_cost_g` calls
:func:`~hev_thermal_env.reward.reward_terms`), so DP, ECMS and the environment's reward value the
same outcomes the same way: fuel, the fuel equivalent of the battery's chemical energy, missed
wheel energy at the miss weight, and (optionally) the overheat terms.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.simulate import CHARGE_PATH_EFF, ENGINE_EFF_AVG
from hev_thermal_env.reward import RewardParams, reward_terms

#: Batches smaller than this are not split over threads (thread start-up would dominate).
MIN_THREAD_BATCH = 4096

_POOL: ThreadPoolExecutor | None = None


def kernel_releases_gil() -> bool:
    """Whether the compiled physics kernel releases the GIL, so that threads run it in parallel."""
    return bool(getattr(C.step_kernel, "targetoptions", {}).get("nogil", False))


def default_threads() -> int:
    return max(1, min(os.cpu_count() or 1, 8))


def _pool(n: int) -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None or _POOL._max_workers < n:  # noqa: SLF001 - sizing check only
        _POOL = ThreadPoolExecutor(max_workers=n, thread_name_prefix="hev-kernel")
    return _POOL


def kernel_step(core: C.PhysicsCore, state: np.ndarray, action: np.ndarray, v0: np.ndarray, v1: np.ndarray,
                grade: np.ndarray, cond: np.ndarray, state_out: np.ndarray, out: np.ndarray,
                threads: int | None = None) -> None:
    """``step_kernel`` on a batch, in ``threads`` slices when the kernel releases the GIL."""
    b = state.shape[0]
    n = default_threads() if threads is None else max(1, int(threads))
    if n == 1 or b < MIN_THREAD_BATCH or not kernel_releases_gil():
        C.step_kernel(*core.params, state, action, v0, v1, grade, cond, core.dt_s, state_out, out)
        return
    edges = np.linspace(0, b, n + 1).astype(int)

    def run(j: int) -> None:
        s = slice(edges[j], edges[j + 1])
        C.step_kernel(*core.params, state[s], action[s], v0[s], v1[s], grade[s], cond[s], core.dt_s, state_out[s],
                      out[s])

    list(_pool(n).map(run, range(n)))


def battery_price_g_per_j(lhv_j_per_g: float) -> float:
    """Grams of fuel per joule of battery chemical energy as priced by the reward (and corrected fuel)."""
    return 1.0 / (lhv_j_per_g * ENGINE_EFF_AVG * CHARGE_PATH_EFF)


#: The equivalence factor (s in fuel + s·E_batt/Q_lhv) that matches the reward's battery price.
REWARD_EQUIVALENCE_FACTOR = 1.0 / (ENGINE_EFF_AVG * CHARGE_PATH_EFF)


def stage_cost_g(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: float,
                 lhv_j_per_g: float, dt_s: float, *, battery: bool = True, soc_deviation: bool = False,
                 overheat: bool = False) -> np.ndarray:
    """Cost in fuel-equivalent grams of each row of a batch step, as the reward prices it.

    Always fuel and missed wheel energy (``reward_fuel + reward_miss``); with ``battery`` the fuel
    equivalent of the battery's chemical energy (the energy part of ``reward_soc``); with
    ``soc_deviation`` the quadratic SOC-deviation part; with ``overheat`` ``reward_overheat``.
    """
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
