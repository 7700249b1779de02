"""Fit the thermal network and the eq 10 closures to the paper's figures, within documented bounds.

The free parameters are the ``ThermalParams`` fields whose doc starts with "fitted:", bounded by the ``min`` and
``max`` of their ``spec``; every candidate is validated by the dataclass. Three deterministic stages (fixed seeds,
one worker): differential evolution of :data:`NETWORK_PARAMS` on the temperature targets (they depend on the
losses, which the closures barely change), differential evolution of :data:`CLOSURE_PARAMS` on every target with
the network held, then a bounded Powell polish of all. Cost: the sum of squared residuals in tolerances
(:meth:`~hev_thermal_env.paper.figures.PaperFigure.residual`), with the heat-index onset taken as the interpolated
zero crossing so the cost is continuous. The values are rounded to 4 significant digits, as written into
``ThermalParams``'s defaults. See docs/thermal_model.md, *Calibration*.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import numpy as np
from scipy import optimize

from ..paper.figures import CALIBRATION_TARGETS, PAPER_FIGURE_BY_NAME
from ..paper.measure import Baseline, cycle_run, measure
from ..physics import ConfigError, VehicleConfig, paper_bus
from ..physics.thermal import ThermalParams

#: The paper's figures the fit is fitted to, in the order of the residual table.
TARGETS = tuple(PAPER_FIGURE_BY_NAME[n] for n in CALIBRATION_TARGETS)
#: The network's parameters, fitted in stage 1.
NETWORK_PARAMS = ("winding_heat_capacity_j_per_k", "winding_conductance_w_per_k", "jacket_conductance_w_per_k",
                  "thermostat_band_k", "coolant_heat_capacity_j_per_k", "radiator_ua_w_per_k")
#: The eq 10 closures and the torque's temperature coefficient, fitted in stage 2.
CLOSURE_PARAMS = ("t_gain_cold", "t_gain_hot", "t_gain_temp_lo_c", "t_gain_temp_hi_c", "pwm_initial_cold",
                  "pwm_initial_temp_lo_c", "pwm_initial_temp_hi_c", "torque_temp_coeff_per_c")
TEMPERATURE_TARGETS = ("udds_temp_peak_c", "udds_temp_last300_c", "beijing_temp_c")

#: Where the fit starts, independent of the current defaults (so a re-run reproduces the fit): the
#: paper's values where it gives them, physical typical values otherwise.
START: dict[str, float] = {
    "winding_heat_capacity_j_per_k": 5000.0,  # 10 kg of copper and 3 kg of insulation and resin
    "winding_conductance_w_per_k": 100.0,  # the winding ~6 K above the housing at the continuous copper loss
    "jacket_conductance_w_per_k": 640.0,  # half the paper's h_water·A
    "thermostat_band_k": 5.0,
    "coolant_heat_capacity_j_per_k": 40e3,  # about 10 L of coolant with the radiator
    "radiator_ua_w_per_k": 200.0,
    "t_gain_cold": 0.1,  # the paper's range [0.1, 0.3]
    "t_gain_hot": 0.3,
    "t_gain_temp_lo_c": 35.0,  # the paper's 35 °C, where its torque and efficiency corrections start
    "t_gain_temp_hi_c": 70.0,  # the cutoff
    "pwm_initial_cold": 0.3,  # the paper's value at its 20 °C start
    "pwm_initial_temp_lo_c": 20.0,
    "pwm_initial_temp_hi_c": 70.0,
    "torque_temp_coeff_per_c": 0.00126,  # NdFeB remanence, the paper's 12.6 % per 100 K
}


def fitted_fields() -> dict[str, tuple[float, float]]:
    """Every ThermalParams field documented as fitted ("fitted: ..."), with its (min, max) bounds."""
    out = {}
    for f in dataclasses.fields(ThermalParams):
        if f.metadata.get("doc", "").startswith("fitted:"):
            lo, hi = f.metadata.get("min"), f.metadata.get("max")
            if lo is None or hi is None:
                raise ValueError(f"ThermalParams.{f.name} is documented as fitted but has no bounds")
            out[f.name] = (float(lo), float(hi))
    return out


def round_sig(x: float, digits: int = 4) -> float:
    if x == 0.0 or not math.isfinite(x):
        return float(x)
    return float(round(x, digits - 1 - int(math.floor(math.log10(abs(x))))))


def with_values(config: VehicleConfig, values: dict[str, float]) -> VehicleConfig:
    """``config`` with thermal fields replaced (raises ConfigError for an invalid combination)."""
    return config.replace(thermal=config.thermal.replace(**{k: float(v) for k, v in values.items()}))


@dataclasses.dataclass
class Stage:
    name: str
    params: tuple[str, ...]
    start: dict[str, float]
    result: dict[str, float]
    cost_start: float
    cost: float
    evaluations: int
    wall_s: float


@dataclasses.dataclass
class FitResult:
    """Fitted values (rounded), the residual of each target at them, and the stages."""

    values: dict[str, float]
    residuals: dict[str, float]
    stages: list[Stage]


class Objective:
    """Cost of the values ``x`` of ``names`` (the other fitted fields at ``fixed``) over ``target_names`` (None:
    every target), with the thermal-off ``baseline`` computed once."""

    def __init__(self, base: VehicleConfig, names: Sequence[str], fixed: dict[str, float],
                 target_names: Sequence[str] | None, baseline: Baseline):
        self.base, self.names, self.fixed, self.baseline = base, tuple(names), dict(fixed), baseline
        self.target_names = tuple(target_names) if target_names is not None else CALIBRATION_TARGETS
        self.evaluations = 0
        self.temperature_only = set(self.target_names) <= set(TEMPERATURE_TARGETS)

    def __call__(self, x: Sequence[float]) -> float:
        self.evaluations += 1
        try:
            cfg = with_values(self.base, {**self.fixed, **dict(zip(self.names, (float(v) for v in x)))})
        except ConfigError:
            return 1e6
        if self.temperature_only:
            u, _ = cycle_run(cfg, "udds")
            b, _ = cycle_run(cfg, "beijing")
            values = {"udds_temp_peak_c": u["temp_peak_c"], "udds_temp_last300_c": u["temp_last300_c"],
                      "beijing_temp_c": b["temp_warm_mean_c"]}
        else:
            m = measure(cfg, self.baseline)
            values = dict(m["values"])
            values["udds_hi_onset_s"] = m["udds"]["hi_onset_smooth_s"]
        return float(sum(PAPER_FIGURE_BY_NAME[n].residual(values[n]) ** 2 for n in self.target_names))


def _powell(obj: Objective, bounds: list[tuple[float, float]], x0: np.ndarray, *, maxfev: int) -> np.ndarray:
    # Powell on the unit cube: equal step scales for parameters of very different magnitudes
    lo = np.array([b[0] for b in bounds])
    span = np.array([b[1] - b[0] for b in bounds])
    res = optimize.minimize(lambda z: obj(lo + np.clip(z, 0.0, 1.0) * span), (x0 - lo) / span, method="Powell",
                            bounds=[(0.0, 1.0)] * len(bounds), options={"maxfev": maxfev, "xtol": 1e-4, "ftol": 1e-6})
    return lo + np.clip(res.x, 0.0, 1.0) * span


def run_fit(base: VehicleConfig | None = None, *, seed: int = 11, de_maxiter: int = 30, de_popsize: int = 8,
            polish_maxfev: int = 600, progress: Callable[[str], None] | None = None) -> FitResult:
    """Run the three stages (module docstring) from :data:`START`; ``base`` (default ``paper_bus()``) gives every
    parameter that is not fitted."""
    say = progress or (lambda msg: None)
    base = base or paper_bus()
    bounds = fitted_fields()
    missing = set(NETWORK_PARAMS + CLOSURE_PARAMS) - set(bounds)
    if missing:
        raise ValueError(f"not documented as fitted: {sorted(missing)}")
    baseline = Baseline(base)
    current = {n: START[n] for n in NETWORK_PARAMS + CLOSURE_PARAMS}
    stages: list[Stage] = []

    def run_stage(name: str, params: tuple[str, ...], target_names: Sequence[str] | None, method: str) -> None:
        t0 = time.perf_counter()
        fixed = {k: v for k, v in current.items() if k not in params}
        obj = Objective(base, params, fixed, target_names, baseline)
        b = [bounds[p] for p in params]
        x0 = np.array([min(max(current[p], lo), hi) for p, (lo, hi) in zip(params, b)])
        c0 = obj(x0)
        if method == "de":
            x = optimize.differential_evolution(obj, b, x0=x0, seed=seed, popsize=de_popsize, maxiter=de_maxiter,
                                                tol=1e-8, mutation=(0.5, 1.0), recombination=0.7, polish=False,
                                                init="sobol", updating="immediate", workers=1).x
        else:
            x = _powell(obj, b, x0, maxfev=polish_maxfev)
        new = {p: min(max(round_sig(float(v)), bounds[p][0]), bounds[p][1]) for p, v in zip(params, x)}
        c1 = obj(np.array([new[p] for p in params]))
        if c1 > c0:  # rounding or a poor search never makes the fit worse than its start
            new, c1 = {p: current[p] for p in params}, c0
        current.update(new)
        stages.append(Stage(name, params, {p: float(v) for p, v in zip(params, x0)}, dict(new), c0, c1,
                            obj.evaluations, time.perf_counter() - t0))
        say(f"stage {name}: cost {c0:.3f} -> {c1:.3f} in {obj.evaluations} runs, {time.perf_counter() - t0:.0f} s")

    run_stage("network", NETWORK_PARAMS, TEMPERATURE_TARGETS, "de")
    run_stage("closures", CLOSURE_PARAMS, None, "de")
    run_stage("polish", NETWORK_PARAMS + CLOSURE_PARAMS, None, "powell")
    values = measure(with_values(base, current), baseline)["values"]
    return FitResult(values=dict(current), residuals={t.name: t.residual(values[t.name]) for t in TARGETS},
                     stages=stages)
