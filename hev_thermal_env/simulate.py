"""Whole-cycle simulation without any environment: a cycle, a vehicle, a split → traces and summary.

A consumer of the physics core like the env, DP and ECMS (cycle → kernel → simulate → metrics).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .cycles import load_cycle
from .metrics import summarize
from .physics import core as C
from .physics.config import Conditions, VehicleConfig, paper_bus

SplitFn = Callable[[int, dict], float]
Split = float | SplitFn | np.ndarray


@dataclasses.dataclass
class SimResult:
    """Per-second traces (``trace[name]`` arrays of length n_steps) and a summary dict."""

    trace: dict[str, np.ndarray]
    summary: dict[str, Any]


def simulate(cycle: Any, config: VehicleConfig | None = None, split: Split = 0.0,
             conditions: Conditions | None = None) -> SimResult:
    """Drive ``cycle`` with ``config`` and a torque split, one step per second.

    Parameters
    ----------
    cycle : a :class:`hev_thermal_env.cycles.Cycle` or anything ``load_cycle`` accepts.
    config : the vehicle (default ``paper_bus()``).
    split : the motor's share u in [-1, 1] of the coupler torque: a constant, an array with one
        value per step, or a callable ``split(k, state) -> u`` where ``state`` holds ``soc``,
        ``motor_temp_c``, ``heat_x``, ``heat_index``, ``motor_cutoff``, ``speed_mps``,
        ``next_speed_mps``, ``grade`` for step ``k``.
    conditions : ambient, starting state and coolant (default ``Conditions()``).

    Returns
    -------
    SimResult with traces of every output of :data:`core.OUT_NAMES` and the state after each step
    (``soc``, ``motor_temp_c``, ``heat_x``, ``motor_cutoff``), and :func:`summarize`'s metrics.
    """
    cyc = load_cycle(cycle)
    config = paper_bus() if config is None else config
    conditions = Conditions() if conditions is None else conditions
    if not isinstance(config, VehicleConfig):
        raise TypeError(f"simulate: config must be a VehicleConfig or None, got {type(config).__name__}")
    if not isinstance(conditions, Conditions):
        raise TypeError(f"simulate: conditions must be a Conditions or None, got {type(conditions).__name__}")
    phys = C.PhysicsCore(config, dt_s=1.0)
    n = cyc.n_steps
    state = phys.initial_state(conditions, 1)
    cond = phys.conditions_array(conditions, 1)
    outs = np.empty((n, C.N_OUT))
    states = np.empty((n, C.N_STATE))
    v = np.asarray(cyc.speed_mps, dtype=np.float64)
    g = np.asarray(cyc.grade, dtype=np.float64)
    const = not callable(split)
    if const:
        u_all = _split_array(split, n)
    a = np.empty(1)
    t0 = time.perf_counter()
    st_out = np.empty((1, C.N_STATE))
    for k in range(n):
        if const:
            a[0] = u_all[k]
        else:
            s = state[0]
            u = float(split(k, {
                "soc": s[C.SOC], "motor_temp_c": s[C.TEMP_C], "heat_x": s[C.HEAT_X],
                "heat_index": min(max(s[C.HEAT_X], 0.0), 1.0), "motor_cutoff": s[C.CUTOFF],
                "speed_mps": v[k], "next_speed_mps": v[k + 1], "grade": g[k]}))
            if not np.isfinite(u):
                raise ValueError(f"split returned {u} at step {k}")
            a[0] = u
        phys.step(state, a, v[k:k + 1], v[k + 1:k + 2], g[k:k + 1], cond, state_out=st_out, out=outs[k:k + 1])
        state, st_out = st_out, state
        states[k] = state[0]
    wall = time.perf_counter() - t0
    trace = step_traces(outs, states)
    trace["time_s"] = np.asarray(cyc.time_s[1:], dtype=np.float64)
    trace["cycle_speed_mps"] = v[1:].copy()
    summary = summarize(trace, config, conditions.initial_soc, cyc.distance_m)
    summary["wall_s"] = wall
    return SimResult(trace=trace, summary=summary)


def step_traces(outs: np.ndarray, states: np.ndarray) -> dict[str, np.ndarray]:
    """Per-step traces of a run: every physics output of ``outs`` [n, N_OUT] and every state of ``states``
    [n, N_STATE] (the state after each step) by name (:mod:`hev_thermal_env.physics.core`), and
    ``heat_index`` = clip(heat_x, 0, 1)."""
    trace = {name: outs[:, i].copy() for i, name in enumerate(C.OUT_NAMES)}
    for i, name in enumerate(C.STATE_NAMES):
        trace[name] = states[:, i].copy()
    trace["heat_index"] = np.clip(trace["heat_x"], 0.0, 1.0)
    return trace


def energy_balance(trace: dict[str, np.ndarray], config: VehicleConfig, dt_s: float = 1.0) -> dict[str, float]:
    """Energy in and out over a run (J) and the relative closing error.

    In: engine brake energy (fuel energy through the engine's efficiency) and battery chemical
    energy. Out: wheel energy delivered, friction brakes, battery, motor, clutch and driveline
    losses and the accessories.
    """
    e_in = float((trace["engine_power_w"].sum() + trace["battery_chem_power_w"].sum()) * dt_s)
    parts = {k: float(trace[k].sum() * dt_s) for k in (
        "wheel_power_w", "brake_power_w", "battery_loss_w", "motor_loss_w", "clutch_loss_w", "driveline_loss_w",
        "accessory_power_w")}
    e_out = sum(parts.values())
    scale = float((np.abs(trace["engine_power_w"]).sum() + np.abs(trace["battery_chem_power_w"]).sum()) * dt_s)
    fuel_j = float(trace["fuel_g"].sum() * config.engine.fuel_lhv_j_per_g)
    return {"energy_in_j": e_in, "energy_out_j": e_out, "relative_error": abs(e_in - e_out) / max(scale, 1.0),
            "fuel_energy_j": fuel_j, **parts}


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
