"""A light driver of a model-based strategy over the physics core, for the paper's runs.

The paper report and the calibration run ADVISOR's rule strategy (``rule``, the paper's own
strategy); the calibration some thousands of times. This driver gives the strategy exactly what
the environment gives it (``core``, ``config``, ``cycle``, ``k``, ``phys_state``, ``peek``) and
steps the same ``PhysicsCore`` with the same float32 action, without the reward and observation
machinery, so a run is a pure function of the vehicle, the cycle and the conditions and equals
the environment's run step for step.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.cycles import Cycle, load_cycle
from hev_thermal_env.physics import Conditions, VehicleConfig
from hev_thermal_env.physics import core as C
from hev_thermal_env.simulate import step_traces


class CoreDriver:
    """The part of ``HevThermalEnv`` a model-based strategy reads, over a bare ``PhysicsCore``."""

    def __init__(self, config: VehicleConfig, cycle: Cycle, conditions: Conditions):
        self.config = config
        self.core = C.PhysicsCore(config)
        self.cycle = cycle
        self.conditions = conditions
        self.k = 0
        self._state = self.core.initial_state(conditions, 1)
        self.cond = self.core.conditions_array(conditions, 1)
        self._v = np.asarray(cycle.speed_mps, dtype=np.float64)
        self._g = np.asarray(cycle.grade, dtype=np.float64)

    @property
    def unwrapped(self) -> CoreDriver:
        return self

    @property
    def phys_state(self) -> np.ndarray:
        return self._state

    def peek(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = np.array(actions, dtype=np.float64).reshape(-1)
        n = a.size
        k = self.k
        return self.core.step(np.repeat(self._state, n, axis=0), a, np.full(n, self._v[k]), np.full(n, self._v[k + 1]),
                              np.full(n, self._g[k]), np.repeat(self.cond, n, axis=0))

    def step(self, u: float) -> tuple[np.ndarray, np.ndarray]:
        k = self.k
        state, out = self.core.step(self._state, np.array([u]), self._v[k:k + 1], self._v[k + 1:k + 2],
                                    self._g[k:k + 1], self.cond)
        self._state = state
        self.k = k + 1
        return state[0], out[0]


def drive(strategy: Any, cycle: str | Cycle, config: VehicleConfig,
          conditions: Conditions | None = None) -> dict[str, np.ndarray]:
    """Run ``strategy`` (a ``agents.base.Strategy``) over ``cycle``; per-step traces of every output and state.

    Returns a dict with every name of ``core.OUT_NAMES`` and ``core.STATE_NAMES`` (the state after
    each step), ``heat_index`` = clip(heat_x, 0, 1), ``u`` (the action applied) and ``time_s``
    (the time at the end of each step).
    """
    cyc = load_cycle(cycle)
    conditions = conditions or Conditions()
    config = strategy.vehicle_config(config)
    env = CoreDriver(config, cyc, conditions)
    strategy.reset(env)
    n = cyc.n_steps
    outs = np.empty((n, C.N_OUT))
    states = np.empty((n, C.N_STATE))
    us = np.empty(n)
    for i in range(n):
        a = np.asarray(strategy.act(None, {}), dtype=np.float32).reshape(1)
        u = min(max(float(a[0]), -1.0), 1.0)
        states[i], outs[i] = env.step(u)
        us[i] = u
    trace = step_traces(outs, states)
    trace["u"] = us
    trace["time_s"] = np.asarray(cyc.time_s[1:], dtype=np.float64)
    return trace
