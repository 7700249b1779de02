"""The runs behind the paper's figures and what is measured on them: the one set of measuring functions of the paper
report, the calibration and the tests.

Every cycle run is the paper's own strategy, ``rule``, in the paper's conditions (ambient, motor and coolant at
20 °C, coolant on), driven over the physics core (:func:`drive`); Table 3's runs have the
coolant closed, the motor starting at 30 or 50 °C. "The motor temperature" is the state's ``motor_temp_c``, the
stator/housing node: the paper's one lumped motor temperature. :func:`target_values` maps the runs to the rows of
:data:`tools.paper.figures.PAPER_FIGURES` (F1-F7, H1-H6 and the checks); :func:`measure` runs what a set
of targets needs.
The heat index's onset and its return to 0 are the interpolated zero crossings of its integrator x (continuous in
the parameters, as the fit needs); an index that never rises has its onset past the cycle's end by 1,000 s per
unit x stayed below 0 and its return at 0 s; one that never returns, past the end by 1,000 s per unit x left.
Top speed and the 4 % grade speed are sustained engine-alone speeds, unchanged by the thermal model.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import Cycle, load_cycle
from hev_thermal_env.metrics import summarize
from hev_thermal_env.physics import Conditions, ThermalParams, VehicleConfig, paper_bus
from hev_thermal_env.physics import core as physics_core
from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics.performance import acceleration_time_s, max_sustained_speed_kmh
from hev_thermal_env.simulate import CoreDriver
from tools.rating import forced_air_term

from .figures import PAPER_FIGURE_BY_NAME, TARGET_BY_ID, TARGETS, PaperFigure

RPM = math.pi / 30.0
#: The paper's conditions for Figs 7-10 and Table 2.
PAPER_CONDITIONS = Conditions()
#: Table 3's runs with the thermal model on: coolant closed, the motor starting at 30 or 50 °C.
TABLE3_HOT_STARTS = {"30c": Conditions(initial_motor_temp_c=30.0, coolant="off"),
                     "50c": Conditions(initial_motor_temp_c=50.0, coolant="off")}
#: H1's band on beijing (Fig. 10): from the first second at ``start_at``, every second within [low, high].
WARM_BAND = TARGET_BY_ID["H1"]
CYCLES = ("udds", "beijing", "hwfet")
#: C6's operating point: first gear at 1.1 m/s (the motor at 1,000 rpm) on a 20 % grade, which asks more than the
#: motor's peak torque; the launch lasts 30 s.
LAUNCH_SPEED_MPS, LAUNCH_GRADE, LAUNCH_S = 1.1, 0.2, 30
#: Seconds of extension per unit of the integrator where a zero crossing is not observed (module docstring).
EXTENSION_S = 1000.0


def _crossing(x: np.ndarray, i: int) -> float:
    """Interpolated time (s, the end of step i is i + 1) at which x crosses 0 between steps i − 1 and i."""
    x_prev = x[i - 1] if i > 0 else 0.0
    return float(i + (0.0 - x_prev) / (x[i] - x_prev)) if x[i] != x_prev else float(i + 1)


def heat_index_figures(trace: Mapping[str, np.ndarray]) -> dict[str, float]:
    """``hi_onset_s`` (x's first crossing above 0, interpolated), ``hi_peak`` and its time, ``hi_return_s`` (from
    the peak to x's crossing back to 0, interpolated), ``hi_onset_observed``; extensions: module docstring."""
    pwm = np.asarray(trace["heat_index"])
    x = np.asarray(trace["heat_x"])
    n = len(x)
    pos = np.flatnonzero(x > 0.0)
    if pos.size == 0:
        return {"hi_onset_s": n + EXTENSION_S * float(-x.max()), "hi_onset_observed": 0.0, "hi_peak": 0.0,
                "hi_peak_time_s": float("nan"), "hi_return_s": 0.0, "hi_max": 0.0}
    onset = _crossing(x, int(pos[0])) if pos[0] > 0 else 0.0
    ip = int(np.argmax(pwm))
    back = np.flatnonzero(x[ip:] <= 0.0)
    ret = (_crossing(x, ip + int(back[0])) if back.size else n + EXTENSION_S * float(x[-1])) - (ip + 1)
    return {"hi_onset_s": onset, "hi_onset_observed": 1.0, "hi_peak": float(pwm[ip]), "hi_peak_time_s": float(ip + 1),
            "hi_return_s": ret, "hi_max": float(pwm.max())}


def warm_figures(temps_c: np.ndarray, band: PaperFigure = WARM_BAND) -> dict[str, float]:
    """Fig. 10's measures from the first second the motor temperature reaches ``band.start_at``: its mean, min,
    max, the largest excursion beyond [low, high] (K) and the seconds outside; NaN where it never gets there."""
    temp = np.asarray(temps_c)
    warm = np.flatnonzero(temp >= band.start_at)
    if warm.size == 0:
        nan = float("nan")
        return {"warm_from_s": nan, "temp_warm_mean_c": nan, "temp_warm_min_c": nan, "temp_warm_max_c": nan,
                "warm_excursion_k": nan, "warm_seconds_outside": nan}
    after = temp[warm[0]:]
    lo, hi = float(after.min()), float(after.max())
    return {"warm_from_s": float(warm[0] + 1), "temp_warm_mean_c": float(after.mean()), "temp_warm_min_c": lo,
            "temp_warm_max_c": hi, "warm_excursion_k": max(0.0, band.low - lo, hi - band.high),
            "warm_seconds_outside": float(((after < band.low) | (after > band.high)).sum())}


class StrategyDriver(CoreDriver):
    """What a model-based strategy reads of ``HevThermalEnv`` (``core``, ``config``, ``cycle``, ``k``, ``phys_state``,
    ``peek``) over a :class:`~hev_thermal_env.simulate.CoreDriver`: light enough for the calibration's thousands of
    runs, a pure function of the vehicle, the cycle and the conditions."""

    @property
    def unwrapped(self) -> StrategyDriver:
        return self

    def peek(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = np.array(actions, dtype=np.float64).reshape(-1)
        n, k = a.size, self.k
        return self.core.step(np.repeat(self.phys_state, n, axis=0), a, np.full(n, self._v[k]),
                              np.full(n, self._v[k + 1]), np.full(n, self._g[k]), np.repeat(self.cond, n, axis=0))


def drive(strategy: Any, cycle: str | Cycle, config: VehicleConfig,
          conditions: Conditions | None = None) -> dict[str, np.ndarray]:
    """Run ``strategy`` (an ``agents.base.Strategy``) over ``cycle`` on a :class:`StrategyDriver`, with the float32
    action the environment gives it (so the run equals the environment's step for step); the traces of
    :meth:`~hev_thermal_env.simulate.CoreDriver.run` and ``u``, the action applied."""
    cyc = load_cycle(cycle)
    conditions = conditions or Conditions()
    config = strategy.vehicle_config(config)
    env = StrategyDriver(config, cyc, conditions)
    strategy.reset(env)
    us = np.empty(cyc.n_steps)

    def act(k: int) -> float:
        a = np.asarray(strategy.act(None, {}), dtype=np.float32).reshape(1)
        us[k] = u = min(max(float(a[0]), -1.0), 1.0)
        return u

    trace = env.run(act)
    trace["u"] = us
    return trace


def cycle_run(config: VehicleConfig, cycle: str, baseline_fuel_l100: float | None = None
              ) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Heat-index, temperature and fuel figures of ``rule`` on ``cycle`` in the paper's conditions, and its trace;
    with ``baseline_fuel_l100`` (the thermal-off run's raw fuel), ``fuel_delta_l100`` too."""
    cyc = load_cycle(cycle)
    tr = drive(get_strategy("rule"), cyc, config, PAPER_CONDITIONS)
    summary = summarize(tr, config, PAPER_CONDITIONS.initial_soc, cyc.distance_m)
    temp = tr["motor_temp_c"]
    winding = tr.get("winding_temp_c", temp)
    m = {**heat_index_figures(tr), "temp_peak_c": float(temp.max()), "temp_min_c": float(temp.min()),
         "temp_last300_c": float(temp[-300:].mean()), **warm_figures(temp),
         "winding_peak_c": float(np.max(winding)), "coolant_peak_c": float(tr["coolant_temp_c"].max()),
         "fuel_l100": summary["fuel_l_per_100km"], "fuel_corrected_l100": summary["fuel_corrected_l_per_100km"],
         "soc_final": summary["soc_final"], "missed_wheel_energy_kwh": summary["missed_wheel_energy_kwh"],
         "derated_s": float((tr["heat_index"] > 0).sum()), "cutoff_s": float((tr["motor_cutoff"] > 0).sum())}
    if baseline_fuel_l100 is not None:
        m["fuel_delta_l100"] = m["fuel_l100"] - baseline_fuel_l100
    return m, tr


def accel_times(config: VehicleConfig, accel_off_s: float | None = None, dt_s: float = 0.1,
                runs: Iterable[str] = ("30c", "50c")) -> dict[str, float]:
    """Table 3's 0-60 km/h times with the coolant closed: thermal off (``accel_off_s`` if measured already), and
    thermal on from each start of ``runs`` ("30c", "50c"), with their differences from thermal off."""
    off = accel_off_s if accel_off_s is not None else acceleration_time_s(
        config.with_thermal(False), Conditions(coolant="off"), dt_s=dt_s)
    out = {"accel_off_s": float(off)}
    for run in runs:
        t = acceleration_time_s(config, TABLE3_HOT_STARTS[run], dt_s=dt_s)
        out[f"accel_{run}_s"], out[f"accel_{run}_delta_s"] = float(t), float(t - off)
    return out


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
    """Our Table 3 row of ``run`` (one of :data:`hev_thermal_env.physics.performance.TABLE3_RUNS`), keyed as
    :func:`hev_thermal_env.physics.performance.table3_paper`."""
    on = "off" if run == "off" else "on"
    return {"top_speed_kmh": t3[f"top_speed_{on}_kmh"], "accel_0_60_s": t3[f"accel_{run}_s"],
            "grade_4pct_speed_kmh": t3[f"grade_speed_{on}_kmh"]}


class Baseline:
    """The thermal-off runs of a vehicle (figures and traces), which no thermal parameter changes: measured once."""

    def __init__(self, config: VehicleConfig, cycles: Iterable[str] = CYCLES):
        off = config.with_thermal(False)
        measured = {c: cycle_run(off, c) for c in cycles}
        self.runs = {c: m for c, (m, _) in measured.items()}
        self.traces = {c: tr for c, (_, tr) in measured.items()}
        self.fuel_l100 = {c: m["fuel_l100"] for c, m in self.runs.items()}
        self.accel_off_s = acceleration_time_s(off, Conditions(coolant="off"), dt_s=0.1)


def measure(config: VehicleConfig, baseline: Baseline | None = None,
            targets: Iterable[PaperFigure] = TARGETS, *, cycles: Iterable[str] = ()) -> dict[str, Any]:
    """The value of each of ``targets`` (default F1-F7 and H1-H6) for ``config`` (thermal model on), running only
    the cycles and Table 3 starts they need (and ``cycles`` besides): ``{"values": {name: value}, "<cycle>":
    cycle_run's figures, "accel": accel_times}``."""
    targets = tuple(targets)
    need = tuple(dict.fromkeys([*(t.cycle for t in targets if t.cycle in CYCLES), *cycles]))
    base = baseline or Baseline(config, need)
    runs = {c: cycle_run(config, c, base.fuel_l100[c])[0] for c in need}
    accel = accel_times(config, base.accel_off_s, runs=[t.cycle for t in targets if t.cycle in TABLE3_HOT_STARTS])
    ours = target_values(runs, accel)
    return {"values": {t.name: ours[t.name] for t in targets}, **runs, "accel": accel}


def target_values(cycles: Mapping[str, Mapping[str, float]], accel: Mapping[str, float]) -> dict[str, float]:
    """Our value of every target F1-H6 whose run is in ``cycles`` (:func:`cycle_run` figures, thermal model on,
    with ``fuel_delta_l100``) or ``accel`` (:func:`accel_times`)."""
    measures = {
        "udds": {"udds_hi_onset_s": "hi_onset_s", "udds_hi_peak": "hi_peak", "udds_hi_return_s": "hi_return_s",
                 "udds_temp_peak_c": "temp_peak_c", "udds_temp_last300_c": "temp_last300_c",
                 "udds_fuel_delta_l100": "fuel_delta_l100"},
        "beijing": {"beijing_warm_band": "warm_excursion_k", "beijing_temp_warm_mean_c": "temp_warm_mean_c",
                    "beijing_hi_max": "hi_max", "beijing_fuel_delta_l100": "fuel_delta_l100"},
        "hwfet": {"hwfet_fuel_delta_l100": "fuel_delta_l100"},
    }
    ours = {name: float(cycles[cyc][key]) for cyc, names in measures.items() if cyc in cycles
            for name, key in names.items()}
    ours.update({f"accel_{run}_delta_s": float(accel[f"accel_{run}_delta_s"]) for run in TABLE3_HOT_STARTS
                 if f"accel_{run}_delta_s" in accel})
    return ours


def figure_values(cycles: Mapping[str, Mapping[str, float]], t3: Mapping[str, float],
                  fig4: Mapping[str, Any] | None = None) -> dict[str, float | None]:
    """Our value of every row of :data:`tools.paper.figures.PAPER_FIGURES` that was measured (None where
    its run did not happen): ``cycles`` maps a cycle to its thermal-model :func:`cycle_run` figures, ``t3`` holds
    :func:`accel_times` and maybe :func:`sustained_speeds`, ``fig4`` is :func:`fig4_curve`."""
    ours: dict[str, float | None] = {name: None for name in PAPER_FIGURE_BY_NAME}
    ours.update(target_values(cycles, t3))
    ours["accel_off_s"] = t3.get("accel_off_s")
    if "top_speed_off_kmh" in t3:
        for on in ("off", "on"):
            ours[f"top_speed_{on}_kmh"] = t3[f"top_speed_{on}_kmh"]
            ours[f"grade_{on}_kmh"] = t3[f"grade_speed_{on}_kmh"]
    if fig4 is not None:
        ours["fig4_leaves_zero_s"], ours["fig4_reaches_one_s"] = fig4["pwm_leaves_zero_s"], fig4["pwm_reaches_one_s"]
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


def heat_flows_w(th: np.ndarray, temp_c: float, ambient_c: float, water_c: float, coolant_factor: float,
                 speed_mps: float) -> tuple[float, float, float]:
    """(Q_air, Q_rad, Q_cool) leaving the paper's node (``paper_eqs``) at ``temp_c`` and the vehicle speed (eqs 1, 4,
    5, 6), from the packed thermal parameters ``th``."""
    ix = thm.IDX
    term = forced_air_term(th[ix.air_speed_per_mps], th[ix.air_speed_exponent], speed_mps)
    g_air = thm.air_conductance_core(th[ix.h_air_base], th[ix.h_air_natural], th[ix.h_air_forced], term,
                                     th[ix.area_m2], temp_c, ambient_c)
    return thm.paper_node_core(g_air, th[ix.eps_sigma_area], th[ix.h_water_area_w_per_k], th[ix.thermostat_temp_c],
                               temp_c, ambient_c, water_c, coolant_factor)


def temperature_step(th: np.ndarray, temp_c: float, heat_w: float, ambient_c: float, water_c: float,
                     coolant_factor: float, speed_mps: float, dt_s: float) -> tuple[float, float, float, float]:
    """One explicit-Euler step of the paper's eq 7 on its node. Returns (new temperature, Q_air, Q_rad, Q_cool)."""
    q_air, q_rad, q_cool = heat_flows_w(th, temp_c, ambient_c, water_c, coolant_factor, speed_mps)
    new = temp_c + dt_s * (heat_w - q_air - q_rad - q_cool) / th[thm.IDX.motor_heat_capacity_j_per_k]
    return float(new), q_air, q_rad, q_cool


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
        q_air, q_rad, q_cool = heat_flows_w(th, temp, 20.0, 20.0, 0.0, speed)
        nets.append(heat - q_air - q_rad - q_cool)
        temp = temperature_step(th, temp, heat, 20.0, 20.0, 0.0, speed, 1.0)[0]
        temps.append(temp)
    net = float(np.mean(nets))
    cutoff = cfg.thermal.cutoff_temp_c
    return {"temps_c": np.array(temps), "cutoff_c": cutoff, "time_to_cutoff_simulated_s": float(len(temps) - 1),
            "time_to_cutoff_analytic_s": float(cfg.thermal.heat_capacity_j_per_k * (cutoff - 20.0) / net),
            "mean_net_heat_w": net, "heat_capacity_j_per_k": cfg.thermal.heat_capacity_j_per_k}


def launch_run(config: VehicleConfig | None = None, warm_max_s: int = 6 * 3600) -> dict[str, Any]:
    """The protocol's check C6 over the physics core: the motor held at its continuous torque at
    :data:`LAUNCH_SPEED_MPS` on :data:`LAUNCH_GRADE` until the network is steady (every node within 1e-3 K over
    a minute, at most ``warm_max_s``), then :data:`LAUNCH_S` s at peak torque (u = 1). The heat index is taken out
    (T_s = 10⁹ s) so that the motor holds its peak; the SOC is held at its start (a rated hour would drain it).
    Returns the steady state, the launch's per-second states (``winding_c``, ``housing_c``, ``coolant_c``, from
    the steady state on) and outputs (``torque_nm``, ``speed_radps``), and ``winding_rise_k``."""
    cfg = config or paper_bus()
    cfg = cfg.replace(thermal=cfg.thermal.replace(t_s_s=1e9))
    core = physics_core.PhysicsCore(cfg)
    state, cond = core.initial_state(PAPER_CONDITIONS, 1), core.conditions_array(PAPER_CONDITIONS, 1)
    v, g = np.array([LAUNCH_SPEED_MPS]), np.array([LAUNCH_GRADE])
    _, out = core.step(state, np.ones(1), v, v, g, cond)
    u_rated = (mot.continuous_torque_nm(cfg.motor.pack(), out[0, physics_core.MOTOR_SPEED])
               * cfg.driveline.coupler_ratio / out[0, physics_core.SHAFT_DEMAND])
    nodes = [physics_core.WINDING_C, physics_core.TEMP_C, physics_core.COOLANT_C]
    history = [state[0, nodes].copy()]
    for k in range(warm_max_s):
        state, _ = core.step(state, np.array([u_rated]), v, v, g, cond)
        state[:, physics_core.SOC] = PAPER_CONDITIONS.initial_soc
        history.append(state[0, nodes].copy())
        if k >= 60 and np.abs(history[-1] - history[-61]).max() < 1e-3:
            break
    temps, outs = [state[0, nodes].copy()], []
    for _ in range(LAUNCH_S):
        state, out = core.step(state, np.ones(1), v, v, g, cond)
        temps.append(state[0, nodes].copy())
        outs.append(out[0, [physics_core.MOTOR_TORQUE, physics_core.MOTOR_SPEED]].copy())
    temps_a, outs_a = np.array(temps), np.array(outs)
    return {"warm_s": float(len(history) - 1), "rated_u": float(u_rated), "winding_c": temps_a[:, 0],
            "housing_c": temps_a[:, 1], "coolant_c": temps_a[:, 2], "torque_nm": outs_a[:, 0],
            "speed_radps": outs_a[:, 1], "winding_rise_k": float(temps_a[-1, 0] - temps_a[0, 0]),
            "winding_over_housing_start_k": float(temps_a[0, 0] - temps_a[0, 1]),
            "winding_over_housing_end_k": float(temps_a[-1, 0] - temps_a[-1, 1])}
