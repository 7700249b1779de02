"""Per-run metrics from a run's traces: fuel, corrected fuel, SOC, heat, misses; the same for every way of driving.

``fuel_corrected_l_per_100km`` puts strategies on equal service: fuel plus the fuel equivalents of
the net battery energy and of the missed wheel energy at :class:`~hev_thermal_env.prices.Prices`
(the reward's prices), each correction also reported on its own.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .physics.config import VehicleConfig
from .prices import Prices


def summarize(trace: dict[str, np.ndarray], config: VehicleConfig, soc_initial: float, distance_m: float,
              dt_s: float = 1.0, prices: Prices | None = None) -> dict[str, Any]:
    """The run's metrics from its traces (arrays of ``fuel_g``, ``battery_chem_power_w``,
    ``missed_wheel_energy_j``, ``soc``, ``motor_temp_c``, ``heat_index``, ``motor_cutoff``,
    ``trace_miss_mps``, ``engine_on``), priced at ``prices`` (default :class:`Prices`)."""
    fuel_g = float(trace["fuel_g"].sum())
    dist_km = max(distance_m / 1000.0, 1e-9)
    dens = config.engine.fuel_density_kg_per_l
    lhv = config.engine.fuel_lhv_j_per_g
    batt_j = float(trace["battery_chem_power_w"].sum() * dt_s)
    miss_j = float(trace["missed_wheel_energy_j"].sum())
    corr_batt_g, corr_miss_g = (prices or Prices()).corrections_g(batt_j, miss_j, lhv)

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


def cycle_distance_m(speed_mps: Any, start: int, steps: int) -> float:
    """Distance of the cycle's speed trace over ``steps`` steps from second ``start`` (trapezoids)."""
    v = np.asarray(speed_mps, dtype=np.float64)
    return float(np.sum(0.5 * (v[start:start + steps] + v[start + 1:start + steps + 1])))


def run_metrics(trace: Mapping[str, np.ndarray], config: VehicleConfig, soc_initial: float, speed_mps: Any,
                start: int, steps: int, dt_s: float, prices: Prices | None = None) -> dict[str, Any]:
    """:func:`summarize` of a run of ``steps`` steps from second ``start`` of a cycle, plus the SOC change.

    What :func:`hev_thermal_env.evaluation.run_strategy` reports and what the evaluation during
    training scores.
    """
    metrics = summarize(trace, config, soc_initial, cycle_distance_m(speed_mps, start, steps), dt_s, prices)
    metrics["delta_soc"] = metrics["soc_final"] - metrics["soc_initial"]
    return metrics
