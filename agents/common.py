"""Helpers shared by the model-based strategies (rule, ECMS, DP).

Every candidate action is evaluated by the one physics step on a batch
(:meth:`hev_thermal_env.physics.PhysicsCore.step`), and priced by the env's own compiled reward
(:func:`hev_thermal_env.envs.reward.stage_cost_g`), so DP, ECMS and the environment value the same
outcomes the same way: fuel, the fuel equivalent of the battery's chemical energy, missed wheel
energy, and (optionally) the SOC-deviation and overheat terms.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import stage_cost_g
from hev_thermal_env.prices import Prices

__all__ = ["REWARD_EQUIVALENCE_FACTOR", "argmin_small_action", "default_threads", "next_step_demand", "stage_cost_g"]

def default_threads() -> int:
    """Threads for large batched physics calls (DP stages): the machine's cores, at most 8."""
    return max(1, min(os.cpu_count() or 1, 8))


#: The equivalence factor (s in fuel + s·E_batt/Q_lhv) that matches the reward's default battery price.
REWARD_EQUIVALENCE_FACTOR = Prices().equivalence_factor()


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
