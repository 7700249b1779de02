"""Whole-cycle simulation without any environment: a cycle, a vehicle, a split → traces and summary."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from . import core as C
from .config import Conditions, VehicleConfig, paper_bus

SplitFn = Callable[[int, dict], float]
Split = float | SplitFn | np.ndarray

# Stated average efficiencies for putting strategies on equal service (DESIGN §6).
ENGINE_EFF_AVG = 0.36  # near FC_CI119's best BSFC (≈225 g/kWh)
CHARGE_PATH_EFF = 0.90  # motor as generator × battery, charging
DRIVELINE_EFF_AVG = 0.93  # gearbox × final drive
DISCHARGE_PATH_EFF = 0.90  # battery × motor, motoring
# Missed wheel energy is charged at what it costs to deliver it from the battery and put that energy
# back with the engine: 1 / (η_engine·η_charge·η_discharge·η_driveline), 1.23 times the fuel the
# engine would burn to deliver it directly, so not driving never pays where the engine could drive.
# The reward uses the same prices (hev_thermal_env.reward), so DP optimises the corrected-fuel metric.


@dataclasses.dataclass
class SimResult:
    """Per-second traces (``trace[name]`` arrays of length n_steps) and a summary dict."""

    trace: dict[str, np.ndarray]
    summary: dict[str, Any]


def battery_price_g_per_j(lhv_j_per_g: float) -> float:
    """Fuel (g) equivalent to one joule of battery chemical energy: what the engine burns to put it back."""
    return 1.0 / (lhv_j_per_g * ENGINE_EFF_AVG * CHARGE_PATH_EFF)


def miss_price_g_per_j(lhv_j_per_g: float) -> float:
    """Fuel (g) charged per joule of missed wheel energy: delivered from the battery, put back by the engine."""
    return 1.0 / (lhv_j_per_g * ENGINE_EFF_AVG * CHARGE_PATH_EFF * DISCHARGE_PATH_EFF * DRIVELINE_EFF_AVG)


def corrections_g(battery_energy_j: float, missed_wheel_energy_j: float, lhv_j_per_g: float) -> tuple[float, float]:
    """Fuel (g) equivalent to net battery energy used and to missed wheel energy.

    Battery: the fuel the engine would burn to put the net chemical energy back, at
    ``ENGINE_EFF_AVG`` × ``CHARGE_PATH_EFF`` (negative when the run ends with more charge).
    Miss: the fuel to deliver the missed wheel energy from the battery (``DISCHARGE_PATH_EFF`` ×
    ``DRIVELINE_EFF_AVG``) and to put that energy back with the engine (``ENGINE_EFF_AVG`` ×
    ``CHARGE_PATH_EFF``): the service a hybrid could have given, at the battery's price.
    """
    return (battery_energy_j * battery_price_g_per_j(lhv_j_per_g),
            missed_wheel_energy_j * miss_price_g_per_j(lhv_j_per_g))


def summarize(trace: dict[str, np.ndarray], config: VehicleConfig, soc_initial: float, distance_m: float,
              dt_s: float = 1.0) -> dict[str, Any]:
    """The run's metrics (DESIGN §6) from its traces."""
    fuel_g = float(trace["fuel_g"].sum())
    dist_km = max(distance_m / 1000.0, 1e-9)
    dens = config.engine.fuel_density_kg_per_l
    lhv = config.engine.fuel_lhv_j_per_g
    batt_j = float(trace["battery_chem_power_w"].sum() * dt_s)
    miss_j = float(trace["missed_wheel_energy_j"].sum())
    corr_batt_g, corr_miss_g = corrections_g(batt_j, miss_j, lhv)

    def l100(g: float) -> float:
        return g / 1000.0 / dens / dist_km * 100.0

    return {
        "distance_km": distance_m / 1000.0,
        "duration_s": float(len(trace["fuel_g"]) * dt_s),
        "fuel_g": fuel_g,
        "fuel_l_per_100km": l100(fuel_g),
        "fuel_corrected_l_per_100km": l100(fuel_g + corr_batt_g + corr_miss_g),
        "soc_correction_l_per_100km": l100(corr_batt_g),
        "miss_correction_l_per_100km": l100(corr_miss_g),
        "battery_energy_kwh": batt_j / 3.6e6,
        "missed_wheel_energy_kwh": miss_j / 3.6e6,
        "soc_initial": float(soc_initial),
        "soc_final": float(trace["soc"][-1]) if len(trace["soc"]) else float(soc_initial),
        "max_motor_temp_c": float(trace["motor_temp_c"].max()) if len(trace["soc"]) else float("nan"),
        "heat_index_max": float(trace["heat_index"].max()) if len(trace["soc"]) else 0.0,
        "derated_s": float((trace["heat_index"] > 0.0).sum() * dt_s),
        "cutoff_s": float((trace["motor_cutoff"] > 0.0).sum() * dt_s),
        "trace_miss_max_mps": float(trace["trace_miss_mps"].max()) if len(trace["soc"]) else 0.0,
        "engine_on_s": float(trace["engine_on"].sum() * dt_s),
    }


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
    from ..cycles import load_cycle

    cyc = load_cycle(cycle)
    config = config or paper_bus()
    conditions = conditions or Conditions()
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
        u_all = np.broadcast_to(np.asarray(split, dtype=np.float64), (n,)).copy()
        if not np.all(np.isfinite(u_all)):
            raise ValueError("split: contains NaN or inf")
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
        C.step_kernel(*phys.params, state, a, v[k:k + 1], v[k + 1:k + 2], g[k:k + 1], cond, phys.dt_s, st_out,
                      outs[k:k + 1])
        state, st_out = st_out, state
        states[k] = state[0]
    wall = time.perf_counter() - t0
    trace = {name: outs[:, i].copy() for i, name in enumerate(C.OUT_NAMES)}
    for i, name in enumerate(C.STATE_NAMES):
        trace[name] = states[:, i].copy()
    trace["heat_index"] = np.clip(trace["heat_x"], 0.0, 1.0)
    trace["time_s"] = np.asarray(cyc.time_s[1:], dtype=np.float64)
    trace["cycle_speed_mps"] = v[1:].copy()
    summary = summarize(trace, config, conditions.initial_soc, cyc.distance_m)
    summary["wall_s"] = wall
    return SimResult(trace=trace, summary=summary)


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
