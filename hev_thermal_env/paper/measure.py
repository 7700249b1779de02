"""The runs behind the paper's figures and what is measured on them, for the report and the calibration alike.

Every cycle run is the paper's own strategy, ``rule``, in the paper's conditions (ambient and motor at 20 °C,
coolant on), driven over the physics core (:func:`hev_thermal_env.simulate.drive`); Table 3's runs have the
coolant closed, the motor starting at 30 or 50 °C. "After warm-up" on beijing: from the first second the motor
reaches 33.5 °C (the lower edge of the paper's band); a motor that never gets there is scored by its maximum. A
heat index that never rises has its onset at ``inf`` and its return at 0 (the "back to 0" row is met trivially).
Top speed and the 4 % grade speed are sustained engine-alone speeds, unchanged by the thermal model.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.metrics import summarize
from hev_thermal_env.physics import Conditions, ThermalParams, VehicleConfig, paper_bus
from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics.performance import acceleration_time_s, max_sustained_speed_kmh
from hev_thermal_env.simulate import drive

from .figures import CALIBRATION_TARGETS, PAPER_FIGURE_BY_NAME, TABLE3_RUNS

RPM = math.pi / 30.0
#: The paper's conditions for Figs 7-10 and Table 2.
PAPER_CONDITIONS = Conditions()
#: Table 3's runs with the thermal model on: coolant closed, the motor starting at 30 or 50 °C.
TABLE3_HOT_STARTS = {"30c": Conditions(initial_motor_temp_c=30.0, coolant="off"),
                     "50c": Conditions(initial_motor_temp_c=50.0, coolant="off")}
WARM_BAND_LOW_C = PAPER_FIGURE_BY_NAME["beijing_temp_c"].paper - PAPER_FIGURE_BY_NAME["beijing_temp_c"].tol
#: Cycles the calibration measures (its targets) and reports beside them.
TARGET_CYCLES = ("udds", "beijing")
BASELINE_CYCLES = ("udds", "beijing", "hwfet")


def heat_index_figures(trace: Mapping[str, np.ndarray]) -> dict[str, float]:
    """``hi_onset_s`` (first second with PWM > 0), ``hi_peak`` and its time, ``hi_return_s`` (seconds from the peak
    back to 0; inf: never), ``hi_onset_smooth_s`` (the integrator's interpolated zero crossing, continuous for the
    fit; without a rise, past the cycle's end by how far the integrator stayed below 0)."""
    pwm = np.asarray(trace["heat_index"])
    x = np.asarray(trace["heat_x"])
    t = np.arange(1, len(pwm) + 1, dtype=float)
    pos = np.flatnonzero(pwm > 0.0)
    if pos.size == 0:
        return {"hi_onset_s": float("inf"), "hi_onset_smooth_s": len(pwm) + 1000.0 * float(-x.max()), "hi_peak": 0.0,
                "hi_peak_time_s": float("nan"), "hi_return_s": 0.0}
    i0 = int(pos[0])
    # the crossing of x through 0 between the last step at or below 0 and the first above
    x_prev = x[i0 - 1] if i0 > 0 else min(x[0], 0.0)
    smooth = t[i0] - 1.0 + (0.0 - x_prev) / max(x[i0] - x_prev, 1e-12) if i0 > 0 else t[i0]
    ip = int(np.argmax(pwm))
    back = np.flatnonzero(pwm[ip:] <= 0.0)
    return {"hi_onset_s": float(t[i0]), "hi_onset_smooth_s": float(smooth), "hi_peak": float(pwm[ip]),
            "hi_peak_time_s": float(t[ip]), "hi_return_s": float(back[0]) if back.size else float("inf")}


def warm_figures(temps_c: np.ndarray) -> dict[str, float]:
    """Motor temperature after warm-up (from the first second at :data:`WARM_BAND_LOW_C`): mean, min, max, and the
    warm-up time."""
    temp = np.asarray(temps_c)
    warm = np.flatnonzero(temp >= WARM_BAND_LOW_C)
    if warm.size == 0:
        return {"temp_warm_mean_c": float(temp.max()), "temp_warm_min_c": float("nan"),
                "temp_warm_max_c": float(temp.max()), "warm_up_s": float("inf")}
    after = temp[warm[0]:]
    return {"temp_warm_mean_c": float(after.mean()), "temp_warm_min_c": float(after.min()),
            "temp_warm_max_c": float(after.max()), "warm_up_s": float(warm[0] + 1)}


def cycle_run(config: VehicleConfig, cycle: str, baseline_fuel_l100: float | None = None
              ) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Heat-index, temperature and fuel figures of ``rule`` on ``cycle`` in the paper's conditions, and its trace;
    with ``baseline_fuel_l100`` (the thermal-off run's raw fuel), ``fuel_delta_l100`` too."""
    cyc = load_cycle(cycle)
    tr = drive(get_strategy("rule"), cyc, config, PAPER_CONDITIONS)
    summary = summarize(tr, config, PAPER_CONDITIONS.initial_soc, cyc.distance_m)
    temp = tr["motor_temp_c"]
    m = {**heat_index_figures(tr), "temp_peak_c": float(temp.max()), "temp_min_c": float(temp.min()),
         "temp_last300_c": float(temp[-300:].mean()), **warm_figures(temp),
         "coolant_peak_c": float(tr["coolant_temp_c"].max()), "fuel_l100": summary["fuel_l_per_100km"],
         "fuel_corrected_l100": summary["fuel_corrected_l_per_100km"], "soc_final": summary["soc_final"],
         "missed_wheel_energy_kwh": summary["missed_wheel_energy_kwh"],
         "derated_s": float((tr["heat_index"] > 0).sum()), "cutoff_s": float((tr["motor_cutoff"] > 0).sum())}
    if baseline_fuel_l100 is not None:
        m["fuel_delta_l100"] = m["fuel_l100"] - baseline_fuel_l100
    return m, tr


def accel_times(config: VehicleConfig, accel_off_s: float | None = None, dt_s: float = 0.1) -> dict[str, float]:
    """Table 3's 0-60 km/h times with the coolant closed: thermal off (``accel_off_s`` if measured already), and
    thermal on from 30 and 50 °C, with their differences from thermal off."""
    off = accel_off_s if accel_off_s is not None else acceleration_time_s(
        config.with_thermal(False), Conditions(coolant="off"), dt_s=dt_s)
    t30, t50 = (acceleration_time_s(config, TABLE3_HOT_STARTS[r], dt_s=dt_s) for r in ("30c", "50c"))
    return {"accel_off_s": off, "accel_30c_s": t30, "accel_50c_s": t50, "accel_30c_delta_s": t30 - off,
            "accel_50c_delta_s": t50 - off}


def sustained_speeds(config: VehicleConfig, resolution_kmh: float = 0.05) -> dict[str, float]:
    """Table 3's top speed and 4 % grade speed (engine alone), thermal off and on."""
    out = {}
    for label, cfg in (("off", config.with_thermal(False)), ("on", config)):
        out[f"top_speed_{label}_kmh"] = max_sustained_speed_kmh(cfg, 0.0, resolution_kmh)
        out[f"grade_speed_{label}_kmh"] = max_sustained_speed_kmh(cfg, 0.04, resolution_kmh)
    return out


def table3(config: VehicleConfig, resolution_kmh: float = 0.05, accel_dt_s: float = 0.1) -> dict[str, float]:
    """Table 3 analog: :func:`sustained_speeds` and :func:`accel_times` in one dict."""
    return {**sustained_speeds(config, resolution_kmh), **accel_times(config, dt_s=accel_dt_s)}


def table3_row(t3: Mapping[str, float], run: str) -> dict[str, float]:
    """Our Table 3 row of ``run`` (one of :data:`~.figures.TABLE3_RUNS`), keyed as :func:`~.figures.table3_paper`."""
    on = "off" if run == "off" else "on"
    return {"top_speed_kmh": t3[f"top_speed_{on}_kmh"], "accel_0_60_s": t3[f"accel_{run}_s"],
            "grade_4pct_speed_kmh": t3[f"grade_speed_{on}_kmh"]}


class Baseline:
    """The thermal-off runs of a vehicle (figures and traces), which no thermal parameter changes: measured once."""

    def __init__(self, config: VehicleConfig, cycles: Iterable[str] = BASELINE_CYCLES):
        off = config.with_thermal(False)
        measured = {c: cycle_run(off, c) for c in cycles}
        self.runs = {c: m for c, (m, _) in measured.items()}
        self.traces = {c: tr for c, (_, tr) in measured.items()}
        self.fuel_l100 = {c: m["fuel_l100"] for c, m in self.runs.items()}
        self.accel_off_s = acceleration_time_s(off, Conditions(coolant="off"), dt_s=0.1)


def measure(config: VehicleConfig, baseline: Baseline | None = None, *, hwfet: bool = False) -> dict[str, Any]:
    """Every calibration target's value for ``config`` (thermal model on), plus diagnostics: ``{"values": {target:
    value}, "udds": {...}, "beijing": {...}, "accel": {...}}`` (and ``"hwfet"`` when asked; :func:`cycle_run`'s
    figures)."""
    base = baseline or Baseline(config)
    cycles = TARGET_CYCLES + (("hwfet",) if hwfet else ())
    runs = {c: cycle_run(config, c, base.fuel_l100[c])[0] for c in cycles}
    accel = accel_times(config, base.accel_off_s)
    ours = figure_values(runs, accel)
    return {"values": {n: ours[n] for n in CALIBRATION_TARGETS}, **runs, "accel": accel}


def figure_values(cycles: Mapping[str, Mapping[str, float]], t3: Mapping[str, float],
                  fig4: Mapping[str, Any] | None = None) -> dict[str, float | None]:
    """Our value of every row of :data:`~.figures.PAPER_FIGURES` that was measured (None where its cycle did not
    run): ``cycles`` maps a cycle to its thermal-model :func:`cycle_run` figures, ``t3`` holds
    :func:`accel_times` and maybe :func:`sustained_speeds`, ``fig4`` is :func:`fig4_curve`."""
    ours: dict[str, float | None] = {k: t3[k] for k in ("accel_off_s", "accel_30c_delta_s", "accel_50c_delta_s")}
    if "top_speed_off_kmh" in t3:
        for run in TABLE3_RUNS:
            row = table3_row(t3, run)
            ours[f"top_speed_{run}_kmh"], ours[f"grade_{run}_kmh"] = row["top_speed_kmh"], row["grade_4pct_speed_kmh"]
    if fig4 is not None:
        ours["fig4_leaves_zero_s"], ours["fig4_reaches_one_s"] = fig4["pwm_leaves_zero_s"], fig4["pwm_reaches_one_s"]
    for cyc in ("udds", "hwfet", "beijing"):
        ours[f"{cyc}_fuel_delta_l100"] = cycles[cyc]["fuel_delta_l100"] if cyc in cycles else None
    udds, beijing = cycles.get("udds", {}), cycles.get("beijing", {})
    ours.update(udds_hi_onset_s=udds.get("hi_onset_s"), udds_hi_peak=udds.get("hi_peak"),
                udds_hi_return_s=udds.get("hi_return_s"), udds_temp_peak_c=udds.get("temp_peak_c"),
                udds_temp_last300_c=udds.get("temp_last300_c"), beijing_temp_c=beijing.get("temp_warm_mean_c"),
                beijing_hi_peak=beijing.get("hi_peak"))
    return ours


def fig4_curve(duration_s: int = 200) -> dict[str, Any]:
    """Fig. 4 analog: heat index and available torque at twice the continuous torque from cold (T_gain 0.3,
    T_s 30 s, PWM_initial 0.3), one value per second."""
    th = ThermalParams(t_gain_cold=0.3, t_gain_hot=0.3, pwm_initial_at_ref=0.3).pack()
    mo = paper_bus().motor.pack()
    w = 2000 * RPM
    cont, peak = mot.continuous_torque_nm(mo, w), mot.peak_torque_nm(mo, w)
    x = x_min = -thm.pwm_initial(th, 20.0)
    t_s = np.arange(0, duration_s + 1)
    pwm, tmax = [], []
    for _ in t_s:
        pwm.append(thm.heat_index_pwm(x))
        tmax.append(thm.available_torque_nm(th, peak, cont, x, 0.0))
        x = thm.heat_index_step(th, x, x_min, 2.0 * cont, cont, 20.0, 1.0)
    pwm_a = np.array(pwm)
    return {"time_s": t_s, "pwm": pwm_a, "torque_nm": np.array(tmax),
            "pwm_leaves_zero_s": float(t_s[np.argmax(pwm_a > 1e-9)] - 1),  # the last second at 0
            "pwm_reaches_one_s": float(t_s[np.argmax(pwm_a >= 1.0 - 1e-9)]),
            "torque_at_saturation_nm": float(tmax[-1]), "continuous_torque_nm": float(cont)}


def cutoff_curve() -> dict[str, Any]:
    """Coolant off, motor at peak power from 20 °C: temperature until the cutoff, and m·c_p·ΔT / mean net heat."""
    cfg = paper_bus()
    th, mo = cfg.thermal.pack(), cfg.motor.pack()
    w = 3600 * RPM
    torque = mot.peak_torque_nm(mo, w)
    speed = 60 / 3.6
    temp, temps, nets = 20.0, [20.0], []
    while temp < cfg.thermal.cutoff_temp_c and len(temps) < 5000:
        heat = mot.total_loss_w(mo, torque, w, cfg.thermal.extra_loss_frac, thm.derate_frac(th, temp))
        q_air, q_rad, q_cool = thm.heat_flows_w(th, temp, 20.0, 20.0, 0.0, speed)
        nets.append(heat - q_air - q_rad - q_cool)
        temp = thm.temperature_step(th, temp, heat, 20.0, 20.0, 0.0, speed, 1.0)[0]
        temps.append(temp)
    net = float(np.mean(nets))
    cutoff = cfg.thermal.cutoff_temp_c
    return {"temps_c": np.array(temps), "cutoff_c": cutoff, "time_to_cutoff_simulated_s": float(len(temps) - 1),
            "time_to_cutoff_analytic_s": float(cfg.thermal.heat_capacity_j_per_k * (cutoff - 20.0) / net),
            "mean_net_heat_w": net, "heat_capacity_j_per_k": cfg.thermal.heat_capacity_j_per_k}
