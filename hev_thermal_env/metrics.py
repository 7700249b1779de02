"""Per-run metrics from a run's traces, the same for every way of driving: fuel, corrected fuel (equal service at
the :class:`~hev_thermal_env.prices.Prices` of the reward), the SAE J1711 charge-sustaining test and the yardstick
cost. See docs/metrics.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .envs.reward import RewardParams, stage_cost_g
from .physics.config import VehicleConfig
from .prices import Prices

J1711_TOLERANCE = 0.01
"""SAE J1711: a run is charge-sustaining when |net battery energy| ≤ this fraction of the fuel energy."""


def summarize(trace: dict[str, np.ndarray], config: VehicleConfig, soc_initial: float, distance_m: float,
              dt_s: float = 1.0) -> dict[str, Any]:
    """The run's metrics from its traces (``fuel_g``, ``battery_chem_power_w``, ``missed_wheel_energy_j``, ``soc``,
    ``motor_temp_c``, ``heat_index``, ``motor_cutoff``, ``trace_miss_mps``, ``engine_on``; ``cost``, the env's safety
    cost per step, where the trace has it: ``safety_cost_s`` is its sum) at :class:`Prices`."""
    fuel_g = float(trace["fuel_g"].sum())
    dist_km = max(distance_m / 1000.0, 1e-9)
    dens = config.engine.fuel_density_kg_per_l
    lhv = config.engine.fuel_lhv_j_per_g
    batt_j = float(trace["battery_chem_power_w"].sum() * dt_s)
    miss_j = float(trace["missed_wheel_energy_j"].sum())
    corr_batt_g, corr_miss_g = Prices().corrections_g(batt_j, miss_j, lhv)
    ratio, sustaining = charge_sustaining(batt_j, fuel_g, lhv)

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
        "net_energy_ratio": ratio,
        "charge_sustaining": sustaining,
        "missed_wheel_energy_kwh": miss_j / 3.6e6,
        "soc_initial": float(soc_initial),
        "soc_final": float(trace["soc"][-1]) if len(trace["soc"]) else float(soc_initial),
        "max_motor_temp_c": float(trace["motor_temp_c"].max()) if len(trace["soc"]) else float("nan"),
        "heat_index_max": float(trace["heat_index"].max()) if len(trace["soc"]) else 0.0,
        "derated_s": float((trace["heat_index"] > 0.0).sum() * dt_s),
        "cutoff_s": float((trace["motor_cutoff"] > 0.0).sum() * dt_s),
        "safety_cost_s": float(trace["cost"].sum()) if "cost" in trace else 0.0,
        "trace_miss_max_mps": float(trace["trace_miss_mps"].max()) if len(trace["soc"]) else 0.0,
        "engine_on_s": float(trace["engine_on"].sum() * dt_s),
    }


def charge_sustaining(battery_energy_j: float, fuel_g: float, lhv_j_per_g: float) -> tuple[float | None, bool]:
    """(net energy ratio, charge-sustaining flag) of SAE J1711: the net chemical energy drawn from the battery (J,
    positive when the run ends with less charge) over the fuel energy, charge-sustaining when at most
    :data:`J1711_TOLERANCE` in magnitude; without fuel, None and charge-sustaining only if the battery is unchanged."""
    fuel_j = float(fuel_g) * float(lhv_j_per_g)
    if fuel_j <= 0.0:
        return None, float(battery_energy_j) == 0.0
    ratio = float(battery_energy_j) / fuel_j
    return ratio, abs(ratio) <= J1711_TOLERANCE


def yardstick_cost_g(out: np.ndarray, state_after: np.ndarray, reward_params: RewardParams, lhv_j_per_g: float,
                     dt_s: float, soc_target: float | np.ndarray = 0.0) -> float:
    """The run's cost (g of fuel equivalent) as the thermal optimum prices it: the sum over the steps (outputs ``out``
    [n, N_OUT], states after ``state_after`` [n, N_STATE]) of :func:`~hev_thermal_env.envs.reward.stage_cost_g`
    without the battery and SOC terms (``soc_target`` does not enter): fuel + the missed wheel energy at the miss
    price + the overheat terms of ``reward_params``."""
    out = np.asarray(out, dtype=np.float64)
    if out.shape[0] == 0:
        return 0.0
    cost = stage_cost_g(reward_params, out, np.asarray(state_after, dtype=np.float64), soc_target, lhv_j_per_g,
                        dt_s, battery=False, soc_deviation=False, overheat=True)
    return float(cost.sum())


def run_metrics(trace: Mapping[str, np.ndarray], config: VehicleConfig, soc_initial: float, speed_mps: Any,
                start: int, steps: int, dt_s: float) -> dict[str, Any]:
    """:func:`summarize` of a run of ``steps`` steps from second ``start`` of a cycle (its distance by trapezoids),
    plus the SOC change: what :func:`~hev_thermal_env.evaluation.run_strategy` and the training's evaluation report."""
    v = np.asarray(speed_mps, dtype=np.float64)
    distance_m = float(np.sum(0.5 * (v[start:start + steps] + v[start + 1:start + steps + 1])))
    metrics = summarize(trace, config, soc_initial, distance_m, dt_s)
    metrics["delta_soc"] = metrics["soc_final"] - metrics["soc_initial"]
    return metrics
