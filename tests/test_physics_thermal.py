"""The motor's thermal model: torque envelope, heat-index floor and derate, the network, the paper's equations as
written, Table 3."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hev_thermal_env import load_cycle, simulate
from hev_thermal_env.physics import Conditions, PhysicsCore, ThermalParams, core, paper_bus
from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics.performance import performance_report
from tools.rating import forced_air_term

RPM = math.pi / 30


def _step(cfg, state, u=1.0, v0=5.0, v1=6.0, cond=None):
    phys = PhysicsCore(cfg)
    cond = cond or Conditions()
    return phys.step(state, np.array([u]), np.array([v0]), np.array([v1]), np.zeros(1), phys.conditions_array(cond))


# --- a derated motor never gets more torque than a cold one --------------------------------------------

def test_envelopes_are_zero_above_max_speed():
    mo = paper_bus().motor.pack()
    for rpm in (6001.0, 6555.0, 9000.0):
        assert mot.peak_torque_nm(mo, rpm * RPM) == 0.0
        assert mot.continuous_torque_nm(mo, rpm * RPM) == 0.0


@pytest.mark.parametrize("heat_x", [0.0, 0.5, 1.0])
def test_available_torque_never_above_the_cold_envelope(heat_x):
    cfg = paper_bus()
    mo, th = cfg.motor.pack(), cfg.thermal.pack()
    for rpm in np.linspace(0.0, 8000.0, 161):
        w = rpm * RPM
        peak = mot.peak_torque_nm(mo, w)
        assert thm.available_torque_nm(th, peak, mot.continuous_torque_nm(mo, w), heat_x, 0.0) <= peak + 1e-12


def test_derated_motor_above_max_speed_gets_nothing_through_the_core():
    """At 35 m/s in top gear the motor turns above 6000 rpm (reachable on US06): fully derated it gives 0 N·m."""
    cfg = paper_bus()
    phys = PhysicsCore(cfg)
    st = phys.initial_state(Conditions(), 1)
    st[0, core.HEAT_X] = 1.0
    _, out = _step(cfg, st, v0=35.0, v1=35.2)
    assert out[0, core.MOTOR_SPEED] > 6000 * RPM
    assert out[0, core.MOTOR_AVAIL] == 0.0
    assert out[0, core.MOTOR_TORQUE] == 0.0


# --- the anti-windup floor follows the motor's state ---------------------------------------------------

def test_hot_started_motor_regains_its_reserve_once_cool():
    cfg = paper_bus()
    phys = PhysicsCore(cfg)
    hot = phys.initial_state(Conditions(initial_motor_temp_c=70.0), 1)
    assert hot[0, core.HEAT_X] == pytest.approx(0.0) and hot[0, core.HEAT_X_MIN] == pytest.approx(0.0)
    cooled = hot.copy()
    cooled[0, core.TEMP_C] = 22.0  # the same integrator state, the motor now cold
    new, _ = _step(cfg, cooled, u=0.0, v0=0.0, v1=0.0)  # standing: no torque, the index relaxes
    assert new[0, core.HEAT_X] < 0.0
    assert new[0, core.HEAT_X_MIN] == pytest.approx(-thm.pwm_initial(phys.th, new[0, core.TEMP_C]))
    # held at standstill, it relaxes down to the cold reserve
    st = new
    for _ in range(2000):
        st, _ = _step(cfg, st, u=0.0, v0=0.0, v1=0.0)
    assert st[0, core.HEAT_X] == pytest.approx(-thm.pwm_initial(cfg.thermal.pack(), st[0, core.TEMP_C]), abs=1e-6)


def test_cold_started_motor_loses_its_reserve_when_hot():
    cfg = paper_bus()
    phys = PhysicsCore(cfg)
    st = phys.initial_state(Conditions(), 1)
    assert st[0, core.HEAT_X] == pytest.approx(-cfg.thermal.pwm_initial_at_ref)
    st[0, core.TEMP_C] = st[0, core.WINDING_C] = 65.0  # heated since the start; the integrator holds the cold reserve
    new, _ = _step(cfg, st, u=0.0, v0=0.0, v1=0.0)
    floor = -thm.pwm_initial(phys.th, new[0, core.TEMP_C])
    assert floor > -0.05  # at 65 °C almost no reserve is left
    assert new[0, core.HEAT_X] >= floor - 1e-12 and new[0, core.HEAT_X_MIN] == pytest.approx(floor)


# --- the derate is exactly −1 percentage point per 15 °C -------------------------------------------------

@pytest.mark.parametrize("temp_c", [50.0, 65.0, 80.0])
@pytest.mark.parametrize("torque, rpm", [(80.0, 2000.0), (240.0, 1500.0), (40.0, 5000.0), (-120.0, 3000.0)])
def test_efficiency_derate_is_one_point_per_15_c(temp_c, torque, rpm):
    cfg = paper_bus()
    mo, th = cfg.motor.pack(), cfg.thermal.pack()
    w = rpm * RPM
    extra = cfg.thermal.extra_loss_frac
    d = thm.derate_frac(th, temp_c)
    assert d == pytest.approx((temp_c - 35.0) / 15.0 * 0.01)
    p_mech = torque * w
    cold = mot.electric_power_w(mo, torque, w, extra, 0.0)
    hot = mot.electric_power_w(mo, torque, w, extra, d)
    if torque > 0:
        eta_cold, eta_hot = p_mech / cold, p_mech / hot
    else:
        eta_cold, eta_hot = cold / p_mech, hot / p_mech
    assert eta_cold - eta_hot == pytest.approx(d, abs=1e-12)
    assert mot.total_loss_w(mo, torque, w, extra, d) == pytest.approx(hot - p_mech, rel=1e-12)


def test_derate_fades_out_at_zero_torque_without_a_jump():
    mo, th = paper_bus().motor.pack(), paper_bus().thermal.pack()
    w = 3000 * RPM
    d = thm.derate_frac(th, 80.0)
    p0 = mot.electric_power_w(mo, 0.0, w, 0.05, d)
    assert p0 == pytest.approx(mot.electric_power_w(mo, 0.0, w, 0.05, 0.0))
    for t in (1e-9, 1e-6, -1e-6):
        assert mot.electric_power_w(mo, t, w, 0.05, d) == pytest.approx(p0, rel=1e-6)


def test_power_limit_solve_under_derate_is_exact():
    mo = paper_bus().motor.pack()
    for rpm, p_dis in ((1000.0, 20e3), (3000.0, 60e3), (5500.0, 90e3), (300.0, 5e3)):
        for d in (0.0, 0.01, 0.03):
            _, t_hi = mot.torque_limits_for_power(mo, rpm * RPM, p_dis, 50e3, 0.05, d, 1e12)
            assert mot.electric_power_w(mo, t_hi, rpm * RPM, 0.05, d) == pytest.approx(p_dis, rel=1e-9)


# --- the network ------------------------------------------------------------------------------------------

def test_network_is_the_default_and_the_paper_equations_are_selectable():
    assert paper_bus().thermal.model == "network"
    assert paper_bus("paper_eqs").thermal.model == "paper_eqs"
    assert paper_bus().with_thermal_model("paper_eqs") == paper_bus("paper_eqs")
    with pytest.raises(ValueError, match="ThermalParams.model"):
        ThermalParams(model="two_node")


def test_paper_equations_as_written_clamp_at_the_thermostat():
    """The literal model: 1282 W/K of coolant with a perfect radiator pins the motor at 35 °C."""
    cfg = paper_bus("paper_eqs")
    for cycle in ("hwfet", "beijing"):
        res = simulate(cycle, cfg, 0.3)
        assert 35.0 < res.summary["max_motor_temp_c"] < 36.0
        assert np.all(res.trace["coolant_temp_c"] == 20.0)  # the coolant node is not used
        np.testing.assert_array_equal(res.trace["winding_temp_c"], res.trace["motor_temp_c"])


def network_step(p, tw, thh, tc, q_w, q_h, amb, coolant_factor, fan_factor, speed_mps, dt_s, q_inv=0.0):
    """One step of the network through ``thermal_step``, the speed's factors computed as the step kernel does:
    (winding, housing, coolant, Q_air, Q_rad, Q_cool, Q_radiator, valve open)."""
    from hev_thermal_env.physics import thermal_network as tnet

    ix = thm.IDX
    forced = forced_air_term(p[ix.air_speed_per_mps], p[ix.air_speed_exponent], speed_mps)
    ram = (speed_mps * p[ix.ram_air_per_mps]) ** p[ix.radiator_air_exponent] if speed_mps > 0.0 else 0.0
    t_h, t_w, t_c, *rest = tnet.thermal_step(p, thh, tw, tc, q_w, q_h, q_inv, amb, amb, coolant_factor, fan_factor,
                                             forced, ram, 1.0 / dt_s)
    return (t_w, t_h, t_c, *rest)


def test_network_steady_state_matches_the_linear_solution():
    """Valve open, fan off, constant speed and heat: the steady temperatures solve the linear network."""
    th = paper_bus().thermal
    p = th.pack()
    q_w, q_h, q_inv, amb, v = 3000.0, 1000.0, 500.0, 20.0, 10.0
    tw, thh, tc = 60.0, 55.0, 30.0
    for _ in range(20000):
        tw, thh, tc, q_air, q_rad, q_cool, q_radiator, on = network_step(p, tw, thh, tc, q_w, q_h, amb, 1.0, 0.0, v,
                                                                         1.0, q_inv)
    assert on == 1.0 and tc >= th.thermostat_temp_c + th.thermostat_band_k  # the valve (on the coolant) is fully open
    # at steady state every node balances
    assert q_w == pytest.approx(th.winding_conductance_w_per_k * (tw - thh), rel=1e-6)
    assert q_w + q_h == pytest.approx(q_air + q_rad + q_cool, rel=1e-6)
    assert q_cool + q_inv == pytest.approx(q_radiator, rel=1e-6)
    # the jacket: ε-NTU with the pump's flow
    mcp = th.coolant_mcp_w_per_k
    g_jacket = mcp * (1.0 - np.exp(-th.jacket_ua_w_per_k / mcp))
    assert thh - tc == pytest.approx(q_cool / g_jacket, rel=1e-6)


def test_network_step_is_stable_and_consistent_across_step_sizes():
    p = paper_bus().thermal.pack()

    def run(dt):
        tw, thh, tc = 20.0, 20.0, 20.0
        for _ in range(int(round(600 / dt))):
            tw, thh, tc, *_ = network_step(p, tw, thh, tc, 4000.0, 1000.0, 20.0, 1.0, 1.0, 8.0, dt)
        return np.array([tw, thh, tc])

    a, b, c = run(0.1), run(1.0), run(10.0)
    np.testing.assert_allclose(a, b, atol=0.3)
    np.testing.assert_allclose(a, c, atol=1.5)


def test_ram_air_and_fan_raise_the_radiator_heat_flow():
    th = paper_bus().thermal
    p = th.pack()

    def q_radiator(coolant_c, speed_mps, fan_factor):  # no heat in the motor: the radiator alone cools the coolant
        return network_step(p, 20.0, 20.0, coolant_c, 0.0, 0.0, 20.0, 1.0, fan_factor, speed_mps, 1.0)[6]

    def expected(coolant_t, ua):  # the step's backward-Euler coolant balance, the valve's flow through the radiator
        valve = min(max((coolant_t - th.thermostat_temp_c) / th.thermostat_band_k, 0.0), 1.0)
        g = valve * th.coolant_mcp_w_per_k * (1.0 - np.exp(-ua / (valve * th.coolant_mcp_w_per_k)))
        c = th.coolant_heat_capacity_j_per_k
        mcp = th.coolant_mcp_w_per_k
        jacket = mcp * (1.0 - np.exp(-th.jacket_ua_w_per_k / mcp))
        # two-node solve (winding and housing at 20 °C hold no heat): coolant, housing, ambient all at 20 except T_c
        return g, c, jacket

    warm = th.fan_on_temp_c - 1.0
    still = q_radiator(warm, 0.0, 1.0)
    assert q_radiator(warm, 20.0, 1.0) > still  # ram air
    hot = th.fan_on_temp_c + th.fan_band_k
    assert q_radiator(hot, 0.0, 1.0) > q_radiator(hot, 0.0, 0.0)  # fan; 0: a failed fan
    # a failed fan at standstill: the still-air UA through the ε-NTU of the open valve's flow
    still_face = th.still_air_speed_mps / th.radiator_ref_air_speed_mps
    ua_still = th.radiator_ua_w_per_k * still_face ** th.radiator_air_exponent
    g_still, _, _ = expected(hot, ua_still)
    assert q_radiator(hot, 0.0, 0.0) / (hot - 20.0) == pytest.approx(g_still, rel=0.05)


def test_coolant_closed_isolates_the_motor_from_the_loop():
    res = simulate("hwfet", paper_bus(), 0.8, Conditions(coolant="off"))
    assert np.all(res.trace["q_cool_w"] == 0.0) and np.all(res.trace["q_radiator_w"] == 0.0)
    assert np.all(res.trace["coolant_on"] == 0.0)
    cooled = simulate("hwfet", paper_bus(), 0.8)
    assert res.summary["max_motor_temp_c"] > cooled.summary["max_motor_temp_c"] + 3.0


def test_thermal_energy_is_conserved_over_a_run():
    cfg = paper_bus()
    th = cfg.thermal
    res = simulate("udds", cfg, 0.5)
    tr = res.trace
    c_w = th.winding_heat_capacity_j_per_k
    c_h = th.heat_capacity_j_per_k - c_w
    stored = (c_w * (tr["winding_temp_c"][-1] - 20.0) + c_h * (tr["motor_temp_c"][-1] - 20.0)
              + th.coolant_heat_capacity_j_per_k * (tr["coolant_temp_c"][-1] - 20.0))
    out = float(np.sum(tr["q_air_w"] + tr["q_rad_w"] + tr["q_radiator_w"]))
    assert stored + out == pytest.approx(float(np.sum(tr["motor_heat_w"] + tr["inverter_heat_w"])), rel=1e-9)
    # the inverter's share: (1 − η)·|P_dc| of every step, never more than the mapped loss
    expect = np.minimum((1.0 - th.inverter_efficiency) * np.abs(tr["motor_elec_power_w"]), tr["motor_loss_w"])
    np.testing.assert_allclose(tr["inverter_heat_w"], expect, rtol=1e-12, atol=1e-9)


def test_hotter_ambient_runs_hotter_and_payload_costs_fuel():
    cool = simulate("udds", paper_bus(), 0.5)
    summer = simulate("udds", paper_bus(), 0.5, Conditions(ambient_temp_c=38.0, initial_motor_temp_c=38.0))
    assert summer.summary["max_motor_temp_c"] > cool.summary["max_motor_temp_c"] + 5.0
    full = simulate("udds", paper_bus(), 0.0, Conditions(payload_kg=4000.0))
    empty = simulate("udds", paper_bus(), 0.0)
    assert full.summary["fuel_g"] > 1.05 * empty.summary["fuel_g"]


def test_empty_battery_never_pays_for_the_spinning_motor():
    """At the SOC floor the motor's iron and friction loss brakes the shaft instead of drawing from the battery."""
    cfg = paper_bus()
    res = simulate("beijing", cfg, 1.0, Conditions(initial_soc=0.42))
    tr = res.trace
    at_floor = tr["soc"] <= cfg.battery.soc_min + 1e-12
    assert at_floor.sum() > 100
    prev = np.concatenate([[0.42], tr["soc"][:-1]]) <= cfg.battery.soc_min + 1e-12
    held = at_floor & prev
    assert np.all(tr["battery_chem_power_w"][held] <= 1e-6)


# --- Table 3 (coolant closed) ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def table3():
    cfg = paper_bus()
    return {
        "off": performance_report(cfg.with_thermal(False), Conditions(coolant="off")),
        "30": performance_report(cfg, Conditions(initial_motor_temp_c=30.0, coolant="off")),
        "50": performance_report(cfg, Conditions(initial_motor_temp_c=50.0, coolant="off")),
    }


def test_table3_thermal_model_slows_the_hot_started_bus(table3):
    off, t30, t50 = table3["off"], table3["30"], table3["50"]
    assert off["accel_0_60_s"] == pytest.approx(16.4, rel=0.05)  # C3: the vehicle's calibration
    # a hotter start costs more time (magnets, derate, the reserve the heat index has left)
    assert t50["accel_0_60_s"] > t30["accel_0_60_s"] > off["accel_0_60_s"]
    # H5, held out of the fit: +0.7 ± 0.2 s from 50 °C (the 30 °C row, F7, is a fitted target the adopted
    # fit misses: +0.15 s against +0.4 ± 0.2 s, docs/calibration/fit_log.md)
    assert t50["accel_0_60_s"] - off["accel_0_60_s"] == pytest.approx(0.7, abs=0.2)
    for key in ("top_speed_kmh", "grade_4pct_speed_kmh"):
        assert t30[key] == off[key] == t50[key]


def test_fig4_case_unchanged_by_the_calibration():
    """Eq 9 with the paper's constants at a held temperature: PWM leaves 0 at 30 s and reaches 1 at 130 s."""
    th = ThermalParams(t_gain_cold=0.3, t_gain_hot=0.3, pwm_initial_at_ref=0.3, pwm_initial_ref_temp_c=20.0).pack()
    x = -thm.pwm_initial(th, 20.0)
    assert x == pytest.approx(-0.3)
    leave = full = None
    for t in range(1, 400):
        x = thm.heat_index_step(th, x, thm.heat_index_floor(th, 20.0), 160.0, 80.0, 20.0, 1.0)
        if leave is None and x > 1e-9:
            leave = t - 1
        if full is None and x >= 1.0 - 1e-9:
            full = t
    assert (leave, full) == (30, 130)


def test_cycle_distance_unchanged_by_payload():
    assert simulate("udds", paper_bus(), 0.0, Conditions(payload_kg=5000.0)).summary["distance_km"] == pytest.approx(
        load_cycle("udds").distance_km)
