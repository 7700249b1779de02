"""The metrics of one run (DESIGN §6) from its per-step trace, the same for every way of driving.

:func:`run_metrics` is what :func:`hev_thermal_env.evaluation.runner.run_strategy` reports and what
the evaluation during training (:mod:`hev_thermal_env.training.evaluator`) scores: the whole-cycle
metrics of :func:`hev_thermal_env.physics.simulate.summarize` plus the SOC change.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from hev_thermal_env.physics import VehicleConfig
from hev_thermal_env.physics.simulate import summarize


def cycle_distance_m(speed_mps: Any, start: int, steps: int) -> float:
    """Distance of the cycle's speed trace over ``steps`` steps from second ``start`` (trapezoids)."""
    v = np.asarray(speed_mps, dtype=np.float64)
    return float(np.sum(0.5 * (v[start:start + steps] + v[start + 1:start + steps + 1])))


def run_metrics(trace: Mapping[str, np.ndarray], config: VehicleConfig, soc_initial: float, speed_mps: Any,
                start: int, steps: int, dt_s: float) -> dict[str, Any]:
    """Fuel, corrected fuel, SOC, temperatures, derating... of a run of ``steps`` steps from ``start``."""
    metrics = summarize(trace, config, soc_initial, cycle_distance_m(speed_mps, start, steps), dt_s)
    metrics["delta_soc"] = metrics["soc_final"] - metrics["soc_initial"]
    return metrics
