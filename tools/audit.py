"""Energy audit of a run from independent quantities: each component against its own map.

The closing balance of :func:`energy_balance` adds up outputs that the step computed from one another, so it
closes whatever the maps say (a wrong fuel map, a SOC held in its window by a clamp, a motor loss at the wrong
point all pass it). The audit takes the operating points the run reports (engine and motor speed and torque,
gear, the states before and after each step, the cycle) and asks each component's own map, and conservation,
what the other columns must be: ``road_load``, ``engine_fuel`` (nothing on overrun), ``engine_efficiency`` (a
diesel's 0.15-0.46, no step above 0.46), ``motor`` (the loss map derated at the temperature before the step),
``battery`` (coulomb counting against −ΔSOC·capacity·V_oc, terminal power from the resistance map and from motor
and accessories), ``driveline`` (efficiencies and the speed chain from the gear), ``balance`` and ``thermal`` (the
motor's heat = heat stored in the nodes + heat given to the air; ``paper_eqs``: the motor node, its coolant flow
leaving the system). Each check reports its worst relative error against its tolerance. docs/thermal_model.md
(Energy audit); ``tests/test_audit.py`` shows each check failing when one component changes alone.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numba import njit

from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.physics import battery, core, driveline, engine, glider, motor, thermal
from hev_thermal_env.physics.config import Conditions, VehicleConfig

#: Each per-step error relative to the component's peak power (or energy) may reach this: rounding is far below it,
#: a changed map far above.
REL_TOL = 1e-6
#: The best brake efficiency a diesel reaches (≈185 g/kWh); no step may convert fuel better.
DIESEL_MAX_EFF = 0.46
DIESEL_MEAN_EFF_RANGE = (0.15, DIESEL_MAX_EFF)


@dataclasses.dataclass
class Check:
    name: str
    error: float
    tol: float
    detail: str = ""

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.error)) and self.error <= self.tol


@dataclasses.dataclass
class AuditReport:
    checks: list[Check]

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.checks)

    def failed(self) -> list[str]:
        return [c.name for c in self.checks if not c.ok]

    def summary(self) -> dict[str, Any]:
        return {c.name: {"error": c.error, "tol": c.tol, "ok": c.ok, "detail": c.detail} for c in self.checks}


# Compiled afresh in each process: numba's own cache would not see a change of the physics kernels it calls.
@njit(cache=False, error_model="numpy")
def _maps(gl, dl, en, mo, th, ba, v0, v1, grade, payload, dt, w_e, t_e_brake, engine_on, t_m, w_m, temp_before,
          soc_before, gear, road_w, fuel_g, p_elec, voc, r_dis, r_chg, ratio):
    for k in range(v0.shape[0]):
        v = 0.5 * (v0[k] + v1[k])
        f = glider.road_force_n(gl, v, (v1[k] - v0[k]) / dt, grade[k], payload) if v > 1e-6 else 0.0
        road_w[k] = f * v
        fuel_g[k] = engine.fuel_rate_gps(en, w_e[k], t_e_brake[k]) * dt if engine_on[k] != 0.0 else 0.0
        derate = thermal.derate_frac(th, temp_before[k])
        p_elec[k] = motor.electric_power_w(mo, t_m[k], w_m[k], thermal.extra_loss_frac(th), derate)
        voc[k] = battery.open_circuit_voltage_v(ba, soc_before[k])
        r_dis[k] = battery.resistance_ohm(ba, soc_before[k], False)
        r_chg[k] = battery.resistance_ohm(ba, soc_before[k], True)
        ratio[k] = driveline.overall_ratio(dl, int(gear[k]) - 1)


def _rel(a: np.ndarray, b: np.ndarray, scale: float) -> float:
    return float(np.max(np.abs(a - b)) / max(scale, 1e-9)) if len(a) else 0.0


def energy_audit(trace: dict[str, np.ndarray], config: VehicleConfig, cycle: Any,
                 conditions: Conditions | None = None) -> AuditReport:
    """Audit a run at 1-s steps (``simulate(...).trace`` or an evaluation trace) of ``config`` over ``cycle``."""
    run = _Run(trace, config, cycle, conditions or Conditions())
    road_w = run.out["road_w"]
    road = Check("road_load", _rel(road_w, run.g["wheel_power_demand_w"], run.peak(road_w)), REL_TOL,
                 "wheel power demand vs the road-load map at the cycle's speed, grade and payload")
    return AuditReport([road, *_engine_checks(run), _motor_check(run), _battery_check(run),
                        _driveline_check(run), _balance_check(run), _thermal_check(run)])


class _Run:
    """What the checks read: the run's outputs ``g``, its states before each step, the maps' values ``out``."""

    def __init__(self, trace: dict[str, np.ndarray], config: VehicleConfig, cycle: Any, conditions: Conditions):
        cyc = load_cycle(cycle)
        dt_s = 1.0
        phys = core.PhysicsCore(config, dt_s=dt_s)
        n = len(trace["fuel_g"])
        v = np.asarray(cyc.speed_mps, dtype=np.float64)
        self.v0, self.v1 = v[:n].copy(), v[1:n + 1].copy()
        grade = np.asarray(cyc.grade, dtype=np.float64)[:n].copy()
        s0 = phys.initial_state(conditions, 1)[0]
        self.config, self.trace, self.dt_s = config, trace, dt_s
        self.idle_radps = config.engine.idle_speed_rpm * np.pi / 30.0
        self.before = {name: np.concatenate([[s0[i]], np.asarray(trace[name])[:-1]])
                       for i, name in enumerate(core.STATE_NAMES)}
        g = self.g = {name: np.asarray(trace[name], dtype=np.float64) for name in core.OUT_NAMES}
        w_e = g["engine_speed_radps"]
        # brake torque of the engine, accessories included, from its reported speed and power
        t_e_brake = np.where(w_e > 0.0, g["engine_power_w"] / np.maximum(w_e, 1e-12), 0.0)
        out = self.out = {k: np.empty(n) for k in ("road_w", "fuel_g", "p_elec", "voc", "r_dis", "r_chg", "ratio")}
        _maps(*phys.params[:6], self.v0, self.v1, grade, float(conditions.payload_kg), dt_s, w_e, t_e_brake,
              g["engine_on"], g["motor_torque_nm"], g["motor_speed_radps"], self.before["motor_temp_c"],
              self.before["soc"], g["gear"], out["road_w"], out["fuel_g"], out["p_elec"], out["voc"], out["r_dis"],
              out["r_chg"], out["ratio"])

    def peak(self, x: np.ndarray) -> float:
        """The largest |x| of the run, the scale of a per-step error (1 for an empty run)."""
        return float(np.max(np.abs(x))) if len(x) else 1.0


def _engine_checks(run: _Run) -> list[Check]:
    g, config, dt_s = run.g, run.config, run.dt_s
    # fuel cut on overrun: a running engine above idle that gives no power burns nothing
    overrun = (g["engine_power_w"] <= 0.0) & (g["engine_speed_radps"] > run.idle_radps * (1.0 + 1e-12))
    fuel = np.where(overrun, 0.0, run.out["fuel_g"])
    fuel_check = Check("engine_fuel", _rel(fuel, g["fuel_g"], run.peak(fuel)), REL_TOL,
                       "fuel per step vs the fuel map at the reported engine speed and brake torque")
    lhv = config.engine.fuel_lhv_j_per_g
    shaft_j = float(np.sum(np.maximum(g["engine_power_w"], 0.0)) * dt_s)
    fuel_j = float(np.sum(g["fuel_g"]) * lhv)
    step_eff = np.where(g["fuel_g"] > 0.0, g["engine_power_w"] * dt_s / np.maximum(g["fuel_g"] * lhv, 1e-12), 0.0)
    mean_eff = shaft_j / fuel_j if fuel_j > 0.0 else 0.0
    lo, hi = DIESEL_MEAN_EFF_RANGE
    eff_err = max(float(np.max(step_eff, initial=0.0)) - DIESEL_MAX_EFF, 0.0) + (
        0.0 if fuel_j == 0.0 or lo <= mean_eff <= hi else min(abs(mean_eff - lo), abs(mean_eff - hi)))
    return [fuel_check, Check("engine_efficiency", eff_err, 0.0,
                              f"shaft energy / fuel energy = {mean_eff:.3f} (diesel: {lo}-{hi}; no step above {hi})")]


def _motor_check(run: _Run) -> Check:
    g, p_elec = run.g, run.out["p_elec"]
    scale = run.peak(p_elec)
    mech = g["motor_torque_nm"] * g["motor_speed_radps"]
    err = max(_rel(p_elec, g["motor_elec_power_w"], scale), _rel(p_elec - mech, g["motor_loss_w"], scale))
    return Check("motor", err, REL_TOL, "electrical power and loss vs the loss map at the reported point, derated at "
                                        "the temperature before the step")


def _battery_check(run: _Run) -> Check:
    g, out, dt_s = run.g, run.out, run.dt_s
    cap_as = run.config.battery.capacity_ah * 3600.0
    d_soc = np.asarray(run.trace["soc"]) - run.before["soc"]
    chem_from_soc = -d_soc * cap_as * out["voc"] / dt_s  # W
    # a charging current stores the coulombic efficiency's share of voc·I (battery.soc_step)
    eta = np.where(g["battery_chem_power_w"] < 0.0, run.config.battery.coulombic_efficiency, 1.0)
    current = g["battery_chem_power_w"] / (eta * np.maximum(out["voc"], 1e-9))
    r = np.where(current >= 0.0, out["r_dis"], out["r_chg"])
    terminal = out["voc"] * current - r * current * current
    acc_elec = np.where(g["engine_on"] != 0.0, 0.0, g["accessory_power_w"])
    scale = run.peak(g["battery_chem_power_w"])
    err = max(_rel(chem_from_soc, g["battery_chem_power_w"], scale), _rel(terminal, g["battery_power_w"], scale),
              _rel(g["motor_elec_power_w"] + acc_elec, g["battery_power_w"], scale))
    e_chem = float(np.sum(g["battery_chem_power_w"]) * dt_s)
    e_soc = float(np.sum(chem_from_soc) * dt_s)
    return Check("battery", err, REL_TOL,
                 f"∫P_chem dt = {e_chem / 3.6e6:.4f} kWh vs −ΔSOC·capacity·V_oc = {e_soc / 3.6e6:.4f} kWh; "
                 "terminal power from the resistance map and the coulombic efficiency, and from the motor and "
                 "accessories")


def _driveline_check(run: _Run) -> Check:
    g, config = run.g, run.config
    eff = config.driveline.gearbox_efficiency * config.driveline.final_drive_efficiency
    shaft_w = g["wheel_power_w"] + g["driveline_loss_w"]
    w_shaft = 0.5 * (run.v0 + run.v1) / config.glider.wheel_radius_m * run.out["ratio"]
    traction = (shaft_w > 0.0) & (g["brake_power_w"] <= 0.0)
    expect = np.where(traction, shaft_w * eff, g["wheel_power_w"])
    # the motor turns at the coupler ratio times the shaft speed the gear gives; the running engine at the shaft
    # speed (idle at least)
    w_scale = max(float(np.max(g["motor_speed_radps"])), 1.0)
    speed_err = max(_rel(w_shaft * config.driveline.coupler_ratio, g["motor_speed_radps"], w_scale),
                    _rel(np.where(g["engine_on"] != 0.0, np.maximum(w_shaft, run.idle_radps), 0.0),
                         g["engine_speed_radps"], w_scale))
    return Check("driveline", max(_rel(expect, g["wheel_power_w"], run.peak(shaft_w)), speed_err), REL_TOL,
                 "wheel power = shaft power × gearbox × final drive efficiency; shaft, motor and engine speeds from "
                 "the gear")


def _balance_check(run: _Run) -> Check:
    g = run.g
    e_in = g["engine_power_w"] + g["battery_chem_power_w"]
    e_out = (g["wheel_power_w"] + g["brake_power_w"] + g["battery_loss_w"] + g["motor_loss_w"] + g["clutch_loss_w"]
             + g["driveline_loss_w"] + g["accessory_power_w"])
    scale = float(np.sum(np.abs(g["engine_power_w"]) + np.abs(g["battery_chem_power_w"]))) if len(e_in) else 1.0
    return Check("balance", abs(float(np.sum(e_in - e_out))) / max(scale, 1.0), 1e-9,
                 "engine shaft + battery chemical energy = wheel, brakes, losses, accessories")


def _thermal_check(run: _Run) -> Check:
    th, g, dt_s = run.config.thermal, run.g, run.dt_s
    heat = (g["motor_heat_w"] + g["inverter_heat_w"]) * dt_s

    def rise(name: str) -> np.ndarray:
        return np.asarray(run.trace[name]) - run.before[name]

    if th.model == "network":
        c_w = th.winding_heat_capacity_j_per_k
        stored = (c_w * rise("winding_temp_c") + (th.heat_capacity_j_per_k - c_w) * rise("motor_temp_c")
                  + th.coolant_heat_capacity_j_per_k * rise("coolant_temp_c"))
        to_air = (g["q_air_w"] + g["q_rad_w"] + g["q_radiator_w"]) * dt_s
        detail = ("winding, housing and coolant heat + convection, radiation and radiator = motor and inverter "
                  "heat")
    else:  # the paper's explicit node: stored = (heat − flows at the old temperature)·dt
        stored = th.heat_capacity_j_per_k * rise("motor_temp_c")
        to_air = (g["q_air_w"] + g["q_rad_w"] + g["q_cool_w"]) * dt_s
        detail = "motor node heat + convection, radiation and coolant = motor heat (eq 7)"
    return Check("thermal", _rel(stored + to_air, heat, max(run.peak(heat), 1.0)), REL_TOL, detail)


def energy_balance(trace: dict[str, np.ndarray], config: VehicleConfig, dt_s: float = 1.0) -> dict[str, float]:
    """Energy in and out over a run (J) and the relative closing error. In: engine brake energy and battery chemical
    energy. Out: wheel energy delivered, friction brakes, battery, motor, clutch and driveline losses, accessories."""
    e_in = float((trace["engine_power_w"].sum() + trace["battery_chem_power_w"].sum()) * dt_s)
    parts = {k: float(trace[k].sum() * dt_s) for k in (
        "wheel_power_w", "brake_power_w", "battery_loss_w", "motor_loss_w", "clutch_loss_w", "driveline_loss_w",
        "accessory_power_w")}
    e_out = sum(parts.values())
    scale = float((np.abs(trace["engine_power_w"]).sum() + np.abs(trace["battery_chem_power_w"]).sum()) * dt_s)
    fuel_j = float(trace["fuel_g"].sum() * config.engine.fuel_lhv_j_per_g)
    return {"energy_in_j": e_in, "energy_out_j": e_out, "relative_error": abs(e_in - e_out) / max(scale, 1.0),
            "fuel_energy_j": fuel_j, **parts}
