"""What a planner needs from an environment (:class:`DPProblem`): every planner here steps it through the one
physics core and prices it with the env's own compiled reward.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.physics.core import N_OUT, N_STATE, SHAFT_DEMAND, PhysicsCore

#: What the action governs at a stage (:meth:`DPProblem.stage_kinds`), by the sign of the shaft demand: the split of a
#: positive demand (u ∈ [-1, 1]); while braking the share u > 0 of the available regeneration (u ≤ 0: friction alone,
#: the same as u = 0); nothing at standstill or zero demand.
TRACTION, BRAKING, IDLE = 1, -1, 0


class DPInfeasibleError(ValueError):
    """No control sequence reaches the final-SOC band on this cycle from this start."""


def default_threads() -> int:
    """Threads for large batched physics calls (DP stages): the machine's cores, at most 8."""
    return max(1, min(os.cpu_count() or 1, 8))


def split_grid(n: int) -> np.ndarray:
    """``n`` splits evenly over [-1, 1], and u = 0 (the motor unused) if that grid misses it."""
    u = np.linspace(-1.0, 1.0, int(n))
    return u if np.any(u == 0.0) else np.sort(np.r_[u, 0.0])


def stage_splits(kind: int, u: np.ndarray) -> np.ndarray:
    """The splits of ``u`` worth trying at a stage of ``kind``: all in traction; while braking the shares in [0, 1]
    (u < 0 brakes like u = 0, which is kept); u = 0 where the action has no effect."""
    if kind == TRACTION:
        return u
    if kind == BRAKING:
        return np.unique(np.r_[0.0, u[u > 0.0]])
    return np.zeros(1)


def argmin_small_action(cost: np.ndarray, actions: np.ndarray, engine_off_from: float = 1.0) -> int:
    """Index of the cheapest candidate; among equally cheap ones (within 1e-9 g, e.g. the motor cut off) the smallest
    |u|, except that a tie wholly within the engine-off band (every tied u >= ``engine_off_from``,
    :attr:`~hev_thermal_env.physics.config.PowertrainParams.engine_off_from`) gives the largest, u = 1."""
    best = float(np.min(cost))
    ties = np.flatnonzero(cost <= best + 1e-9)
    if ties.size == 1:
        return int(ties[0])
    tied = actions[ties]
    if tied.min() >= engine_off_from:
        return int(ties[np.argmax(tied)])
    return int(ties[np.argmin(np.abs(tied))])


@dataclass
class DPProblem:
    """What DP needs from an environment: the vehicle, the cycle from step ``k0``, the start, the prices."""

    core: PhysicsCore
    speed_mps: np.ndarray
    grade: np.ndarray
    k0: int
    state0: np.ndarray  # [N_STATE]
    cond: np.ndarray  # [N_COND]
    reward_params: RewardParams
    soc_target: float
    name: str = "cycle"

    @classmethod
    def from_env(cls, env: Any) -> DPProblem:
        e = env.unwrapped if hasattr(env, "unwrapped") else env
        return cls(core=e.core, speed_mps=np.asarray(e.cycle.speed_mps, dtype=np.float64),
                   grade=np.asarray(e.cycle.grade, dtype=np.float64), k0=int(e.k),
                   state0=np.array(e.phys_state[0], dtype=np.float64), cond=np.array(e.cond[0], dtype=np.float64),
                   reward_params=e.reward_params, soc_target=float(e.soc_target),
                   name=getattr(e.cycle, "name", "cycle"))

    @property
    def n_stages(self) -> int:
        return len(self.speed_mps) - 1 - self.k0

    @property
    def lhv(self) -> float:
        return self.core.config.engine.fuel_lhv_j_per_g

    def key(self) -> str:
        h = hashlib.sha1()
        for a in (self.speed_mps, self.grade, self.state0, self.cond, *self.core.params):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(repr((self.k0, self.reward_params, self.soc_target, self.core.dt_s)).encode())
        return h.hexdigest()

    def stage_inputs(self, i: int, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = self.k0 + i
        return (np.full(b, self.speed_mps[k]), np.full(b, self.speed_mps[k + 1]), np.full(b, self.grade[k]))

    def step(self, states: np.ndarray, actions: np.ndarray | float, i: int) -> tuple[np.ndarray, np.ndarray]:
        """The physics step of stage i for a small batch (planning helpers: the corridor, the heat prices, replays),
        by :meth:`~hev_thermal_env.physics.core.PhysicsCore.step_unchecked`: the inputs are the planner's own float64
        arrays, and the door's checks would cost more than a few rows' step."""
        if states.ndim != 2 or states.shape[1] != N_STATE:
            raise ValueError(f"DPProblem.step: states must have shape (B, {N_STATE}), got {states.shape}")
        b = states.shape[0]
        act = np.full(b, actions, dtype=np.float64)
        so, out = np.empty((b, N_STATE)), np.empty((b, N_OUT))
        self.core.step_unchecked(np.ascontiguousarray(states, dtype=np.float64), act, *self.stage_inputs(i, b),
                                 np.ascontiguousarray(np.broadcast_to(self.cond, (b, self.cond.size))), so, out)
        return so, out

    def stage_kinds(self) -> np.ndarray:
        """Per stage :data:`TRACTION`, :data:`BRAKING` or :data:`IDLE`: the sign of its shaft demand, which the state
        does not change (the gear follows the speed and the road load)."""
        n = self.n_stages
        k = self.k0
        _, out = self.core.step(np.repeat(self.state0[None, :], n, axis=0), 0.0, self.speed_mps[k:-1],
                                self.speed_mps[k + 1:], self.grade[k:k + n], self.cond)
        return np.sign(out[:, SHAFT_DEMAND]).astype(np.int64)

    def extreme_actions(self) -> np.ndarray:
        """Per stage [n_stages, 2], the action of the most discharge and of the most charge: in traction u = +1 (the
        motor asked for the whole demand) and u = −1 (the engine up to twice the demand or its full load); while braking
        u = 0 (no regeneration, the spinning motor's loss drawn from the battery) and u = 1 (all the available
        regeneration)."""
        kind = self.stage_kinds()
        discharge = np.where(kind == TRACTION, 1.0, 0.0)
        charge = np.where(kind == TRACTION, -1.0, np.where(kind == BRAKING, 1.0, 0.0))
        return np.column_stack([discharge, charge])
