"""Whole-cycle simulation without any environment: a cycle, a vehicle and a split (:func:`simulate`) → per-step
traces (a model-based strategy on :class:`CoreDriver`: the workshop's ``tools.paper.measure.drive``).

A consumer of the physics core like the env, DP and ECMS (cycle → kernel → simulate → metrics).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .cycles import Cycle, load_cycle
from .metrics import summarize
from .physics import core
from .physics.config import Conditions, VehicleConfig, paper_bus

Split = float | Callable[[int, dict], float] | np.ndarray


@dataclasses.dataclass
class SimResult:
    """Per-second traces (``trace[name]`` arrays of length n_steps) and a summary dict."""

    trace: dict[str, np.ndarray]
    summary: dict[str, Any]


class CoreDriver:
    """A bare ``PhysicsCore`` stepping a cycle (``core``, ``config``, ``cycle``, ``k``, ``phys_state`` as
    ``HevThermalEnv`` names them), without the reward and observation machinery: a pure function of the vehicle, the
    cycle and the conditions."""

    def __init__(self, config: VehicleConfig, cycle: Cycle, conditions: Conditions):
        self.config, self.cycle, self.conditions, self.k = config, cycle, conditions, 0
        self.core = core.PhysicsCore(config)
        self.phys_state = self.core.initial_state(conditions, 1)
        self.cond = self.core.conditions_array(conditions, 1)
        self._v = np.asarray(cycle.speed_mps, dtype=np.float64)
        self._g = np.asarray(cycle.grade, dtype=np.float64)

    def step(self, u: float) -> tuple[np.ndarray, np.ndarray]:
        k = self.k
        state, out = self.core.step(self.phys_state, np.array([u]), self._v[k:k + 1], self._v[k + 1:k + 2],
                                    self._g[k:k + 1], self.cond)
        self.phys_state, self.k = state, k + 1
        return state[0], out[0]

    def run(self, action: Callable[[int], float]) -> dict[str, np.ndarray]:
        """Step to the end of the cycle with u = ``action(k)``; :func:`step_traces` and ``time_s`` (the end of
        each step)."""
        n = self.cycle.n_steps
        outs, states = np.empty((n, core.N_OUT)), np.empty((n, core.N_STATE))
        for k in range(n):
            states[k], outs[k] = self.step(action(k))
        trace = step_traces(outs, states)
        trace["time_s"] = np.asarray(self.cycle.time_s[1:], dtype=np.float64)
        return trace


def simulate(cycle: Any, config: VehicleConfig | None = None, split: Split = 0.0,
             conditions: Conditions | None = None) -> SimResult:
    """Drive ``cycle`` (anything ``load_cycle`` accepts) with ``config`` (default ``paper_bus()``) in ``conditions``
    (default ``Conditions()``), one step per second; ``split``, the motor's share u in [-1, 1] of the coupler torque,
    is a constant, one value per step or ``split(k, state) -> u`` with ``state`` holding ``soc``, ``motor_temp_c``,
    ``heat_x``, ``heat_index``, ``motor_cutoff``, ``speed_mps``, ``next_speed_mps`` and ``grade`` of step ``k``.
    Returns the traces of :func:`step_traces`, ``time_s`` and ``cycle_speed_mps``, and :func:`summarize`'s metrics."""
    cyc = load_cycle(cycle)
    config = paper_bus() if config is None else config
    conditions = Conditions() if conditions is None else conditions
    if not isinstance(config, VehicleConfig):
        raise TypeError(f"simulate: config must be a VehicleConfig or None, got {type(config).__name__}")
    if not isinstance(conditions, Conditions):
        raise TypeError(f"simulate: conditions must be a Conditions or None, got {type(conditions).__name__}")
    driver = CoreDriver(config, cyc, conditions)
    v, g = driver._v, driver._g

    def called(k: int) -> float:
        s = driver.phys_state[0]
        u = float(split(k, {
            "soc": s[core.SOC], "motor_temp_c": s[core.TEMP_C], "heat_x": s[core.HEAT_X],
            "heat_index": min(max(s[core.HEAT_X], 0.0), 1.0), "motor_cutoff": s[core.CUTOFF],
            "speed_mps": v[k], "next_speed_mps": v[k + 1], "grade": g[k]}))
        if not np.isfinite(u):
            raise ValueError(f"split returned {u} at step {k}")
        return u

    action = called if callable(split) else _split_array(split, cyc.n_steps).__getitem__
    t0 = time.perf_counter()
    trace = driver.run(action)
    wall = time.perf_counter() - t0
    trace["cycle_speed_mps"] = v[1:].copy()
    summary = {**summarize(trace, config, conditions.initial_soc, cyc.distance_m), "wall_s": wall}
    return SimResult(trace=trace, summary=summary)


def step_traces(outs: np.ndarray, states: np.ndarray) -> dict[str, np.ndarray]:
    """Every physics output of ``outs`` [n, N_OUT] and state of ``states`` [n, N_STATE] (after each step) by name
    (:mod:`hev_thermal_env.physics.core`), and ``heat_index`` = clip(heat_x, 0, 1)."""
    trace = {name: outs[:, i].copy() for i, name in enumerate(core.OUT_NAMES)}
    for i, name in enumerate(core.STATE_NAMES):
        trace[name] = states[:, i].copy()
    trace["heat_index"] = np.clip(trace["heat_x"], 0.0, 1.0)
    return trace


def _split_array(split: Any, n: int) -> np.ndarray:
    """A constant or per-step ``split`` as n finite values (one-line ValueError otherwise)."""
    try:
        u = np.asarray(split, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"split: expected a number, an array of {n} numbers or a callable, got {split!r}") from None
    if u.ndim > 1 or (u.ndim == 1 and u.size != n):
        raise ValueError(f"split: an array needs one value per step ({n} for this cycle), got shape {u.shape}")
    if not np.all(np.isfinite(u)):
        raise ValueError("split: contains NaN or inf")
    return np.broadcast_to(u, (n,)).copy()
