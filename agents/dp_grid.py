"""The grid side of dynamic programming: the problem over a known cycle, the settings, the plan and its lookup.

:class:`DPProblem` holds the cycle, the start state and the physics core of one solve;
:class:`DPSettings` the grid sizes and prices; :class:`DPPlan` the cost-to-go on the stage grids,
read back by multilinear interpolation (:func:`interp_uniform`, compiled). Used by
:mod:`hev_thermal_env.agents.dp` (the solver and the strategies) and
:mod:`hev_thermal_env.agents.dp_corridor` (the reachable SOC band).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.physics import core as C
from hev_thermal_env.physics.jit import jit

DIM_COLUMNS = {"soc": C.SOC, "heat_x": C.HEAT_X, "temp": C.TEMP_C}


class DPInfeasibleError(ValueError):
    """No control sequence reaches the final-SOC band on this cycle from this start."""


@jit
def interp_uniform(values, lo, step, n, states, cols, wall, result):
    """Multilinear interpolation of ``values`` (flattened, C order, shape ``n``) on a uniform grid.

    ``lo``, ``step``, ``n`` per dimension; the point of row b is ``states[b, cols]``. Dimension 0 (SOC) continues beyond
    its ends with slope ``wall`` (value at the end + wall × distance); the others are clamped.
    """
    d_count = lo.shape[0]
    stride = np.empty(d_count, dtype=np.int64)
    s = 1
    for d in range(d_count - 1, -1, -1):
        stride[d] = s
        s *= n[d]
    idx = np.empty(d_count, dtype=np.int64)
    w = np.empty(d_count)
    for b in range(states.shape[0]):
        excess = 0.0
        for d in range(d_count):
            f = (states[b, cols[d]] - lo[d]) / step[d]
            top = n[d] - 1.0
            if f < 0.0:
                if d == 0:
                    excess = (0.0 - f) * step[d]
                f = 0.0
            elif f > top:
                if d == 0:
                    excess = (f - top) * step[d]
                f = top
            i = min(int(f), n[d] - 2)
            idx[d] = i
            w[d] = f - i
        acc = 0.0
        for corner in range(1 << d_count):
            weight = 1.0
            flat = 0
            for d in range(d_count):
                if (corner >> d) & 1:
                    weight *= w[d]
                    flat += (idx[d] + 1) * stride[d]
                else:
                    weight *= 1.0 - w[d]
                    flat += idx[d] * stride[d]
            if weight != 0.0:
                acc += weight * values[flat]
        result[b] = acc + wall * excess


@dataclass
class DPPlan:
    """A solved DP: the cost-to-go on the state grid of every stage, and how it was made.

    The SOC grid of stage i has ``n_soc`` points from ``soc_lo[i]`` to ``soc_hi[i]`` (the corridor);
    the other dimensions have the fixed grids ``grids[1:]``.
    """

    dims: tuple[str, ...]
    grids: list[np.ndarray]  # grids[0] is unused (the SOC grid varies per stage); the others are fixed
    soc_lo: np.ndarray  # [n_stages + 1]
    soc_hi: np.ndarray  # [n_stages + 1]
    cost_to_go: np.ndarray  # [n_stages + 1, n_states], flattened grid in C order (SOC-major)
    k0: int
    held: np.ndarray  # [n_stages + 1, N_STATE]: values of the columns that are not DP states, per stage
    soc_final: float
    soc_tol: float
    wall_g_per_soc: float
    solve_s: float
    n_evals: int
    info: dict = field(default_factory=dict)

    @property
    def n_stages(self) -> int:
        return self.cost_to_go.shape[0] - 1

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(g) for g in self.grids)

    def soc_grid(self, stage: int) -> np.ndarray:
        return np.linspace(self.soc_lo[stage], self.soc_hi[stage], len(self.grids[0]))

    def _axes(self, stage: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = np.array(self.shape, dtype=np.int64)
        lo = np.array([self.soc_lo[stage]] + [g[0] for g in self.grids[1:]])
        step = np.array([(self.soc_hi[stage] - self.soc_lo[stage]) / (n[0] - 1)]
                        + [g[1] - g[0] for g in self.grids[1:]])
        return lo, step, n

    def lookup(self, stage: int, states: np.ndarray) -> np.ndarray:
        """Cost-to-go at ``stage`` (0 = plan start) of full states [B, N_STATE]."""
        cols = np.array([DIM_COLUMNS[d] for d in self.dims], dtype=np.int64)
        res = np.empty(states.shape[0])
        lo, step, n = self._axes(stage)
        interp_uniform(self.cost_to_go[stage], lo, step, n, np.ascontiguousarray(states), cols, self.wall_g_per_soc,
                       res)
        return res


@dataclass
class DPProblem:
    """What DP needs from an environment: the vehicle, the cycle from step ``k0``, the start, the prices."""

    core: C.PhysicsCore
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

    def step(self, states: np.ndarray, actions: np.ndarray, i: int) -> tuple[np.ndarray, np.ndarray]:
        """The physics step of stage i for a small batch (planning helpers)."""
        v0, v1, g = self.stage_inputs(i, states.shape[0])
        return self.core.step(states, actions, v0, v1, g, self.cond)

    def demand_positive(self) -> np.ndarray:
        """Whether the shaft demand of each stage is positive (else the action has no effect)."""
        n = self.n_stages
        k = self.k0
        _, out = self.core.step(np.repeat(self.state0[None, :], n, axis=0), 0.0, self.speed_mps[k:-1],
                                self.speed_mps[k + 1:], self.grade[k:k + n], self.cond)
        return out[:, C.SHAFT_DEMAND] > 0.0


@dataclass
class DPSettings:
    """Grid and pricing options of a DP solve (see the module docstring)."""

    dims: tuple[str, ...] = ("soc",)
    n_soc: int = 401
    n_heat_x: int = 21
    n_temp: int = 11
    n_u: int = 41
    n_u_exec: int = 101
    temp_range_c: tuple[float, float] | None = None  # default: [min(start, ambient, water), cutoff + 2]
    soc_final: float | None = None  # default: the initial SOC
    soc_tol: float = 0.005
    on_infeasible: str = "raise"
    penalty_g_per_soc: float = 1e6
    price_overheat: bool = False
    price_soc_deviation: bool = False
    threads: int | None = None

    def sizes(self) -> dict[str, int]:
        return {"soc": self.n_soc, "heat_x": self.n_heat_x, "temp": self.n_temp}


def fixed_grids(problem: DPProblem, s: DPSettings) -> list[np.ndarray]:
    """Grids of the non-SOC dimensions (the SOC entry is a placeholder of the right length)."""
    cfg = problem.core.config
    grids = []
    for d in s.dims:
        n = s.sizes()[d]
        if n < 2:
            raise ValueError(f"dp: the {d} grid needs at least 2 points, got {n}")
        if d == "soc":
            lo, hi = 0.0, 1.0
        elif d == "heat_x":
            lo, hi = float(problem.state0[C.HEAT_X_MIN]), 1.0
            if hi - lo < 1e-6:
                lo = hi - 1.0
        else:
            t0 = float(problem.state0[C.TEMP_C])
            lo, hi = s.temp_range_c or (min(t0, float(problem.cond[C.AMBIENT_C]), float(problem.cond[C.WATER_C])),
                                        cfg.thermal.cutoff_temp_c + 2.0)
        grids.append(np.linspace(float(lo), float(hi), int(n)))
    return grids
