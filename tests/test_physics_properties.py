"""Property tests (hypothesis) on each physics component and on the batched step."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from hev_thermal_env.physics import Conditions, PhysicsCore, core, paper_bus
from hev_thermal_env.physics import battery as bat
from hev_thermal_env.physics import engine as eng
from hev_thermal_env.physics import glider as gli
from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm

CFG = paper_bus()
GL, DL, EN, MO, TH, BA, PT = PhysicsCore(CFG).params
RPM = math.pi / 30
speeds = st.floats(0.0, 6000 * RPM)
torques = st.floats(0.0, 240.0)
temps = st.floats(-20.0, 120.0)
socs = st.floats(0.4, 0.8)
fast = settings(max_examples=200, deadline=None)


@fast
@given(speeds, torques, torques)
def test_motor_more_torque_more_loss(w, t1, t2):
    lo, hi = sorted((t1, t2))
    assert mot.base_loss_w(MO, hi, w) >= mot.base_loss_w(MO, lo, w)
    assert mot.base_loss_w(MO, -hi, w) >= mot.base_loss_w(MO, -lo, w)
    assert mot.electric_power_w(MO, hi, w, 0.05, 0.0) >= mot.electric_power_w(MO, lo, w, 0.05, 0.0)


@fast
@given(speeds, torques, temps, temps)
def test_hotter_motor_loses_more(w, t, temp1, temp2):
    lo, hi = sorted((temp1, temp2))
    l_lo = mot.total_loss_w(MO, t, w, 0.05, thm.derate_frac(TH, lo))
    l_hi = mot.total_loss_w(MO, t, w, 0.05, thm.derate_frac(TH, hi))
    assert l_hi >= l_lo


@fast
@given(temps, temps)
def test_hotter_start_less_overload_reserve(temp1, temp2):
    lo, hi = sorted((temp1, temp2))
    assert thm.pwm_initial(TH, hi) <= thm.pwm_initial(TH, lo)
    assert thm.t_gain(TH, hi) >= thm.t_gain(TH, lo)


@fast
@given(speeds, st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_more_heat_index_less_torque(w, x1, x2):
    lo, hi = sorted((x1, x2))
    peak, cont = mot.peak_torque_nm(MO, w), mot.continuous_torque_nm(MO, w)
    a_lo = thm.available_torque_nm(TH, peak, cont, lo, 0.0)
    a_hi = thm.available_torque_nm(TH, peak, cont, hi, 0.0)
    assert a_hi <= a_lo + 1e-12
    assert min(cont, peak) - 1e-9 <= a_hi <= peak + 1e-9
    assert thm.available_torque_nm(TH, peak, cont, lo, 1.0) == 0.0


@fast
@given(speeds, st.floats(0.0, 150e3), st.floats(0.0, 150e3), st.floats(0.0, 0.05))
@example(1.19e-7, 70.0, 0.0, 0.03125)  # near standstill with a derate: the two Newton steps end 1.5e-8 above
def test_motor_power_limits_respected(w, p_dis, p_chg, derate):
    """The torque range keeps the electrical power within the battery's limits: exactly (to rounding) without a
    derate, and with one to the two Newton steps' accuracy, 1e-7 of the limit (at 1.2e-7 rad/s, 70 W and a 3 %
    derate the motoring limit ends 1.5e-8 of it above)."""
    t_lo, t_hi = mot.torque_limits_for_power(MO, w, p_dis, p_chg, 0.05, derate, 1e12)
    assert t_lo <= min(t_hi, 0.0)
    if t_hi < 0.0:  # only when even zero torque needs more than the battery gives: the motor brakes on its loss
        assert mot.electric_power_w(MO, 0.0, w, 0.05, derate) > p_dis
    if t_hi > 0:
        assert mot.electric_power_w(MO, t_hi, w, 0.05, derate) <= p_dis * (1 + 1e-7) + 1e-6
    if t_lo < 0:
        assert mot.electric_power_w(MO, t_lo, w, 0.05, derate) >= -p_chg * (1 + 1e-9) - 1e-6


@fast
@given(st.floats(700 * RPM, 3500 * RPM), st.floats(0.0, 400.0), st.floats(0.0, 400.0))
def test_engine_more_torque_more_fuel(w, t1, t2):
    lo, hi = sorted((t1, t2))
    assert eng.fuel_rate_gps(EN, w, hi) >= eng.fuel_rate_gps(EN, w, lo) >= 0.0
    assert eng.max_torque_nm(EN, w) > 0.0


@fast
@given(st.floats(0.01, 40.0), st.floats(0.01, 40.0), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), st.floats(-2, 2))
def test_road_force_monotone(v1, v2, g1, g2, a):
    vl, vh = sorted((v1, v2))
    gl_, gh = sorted((g1, g2))
    assert gli.road_force_n(GL, vh, a, 0.0, 0.0) >= gli.road_force_n(GL, vl, a, 0.0, 0.0)
    assert gli.road_force_n(GL, vl, a, gh, 0.0) >= gli.road_force_n(GL, vl, a, gl_, 0.0)


@fast
@given(socs, st.floats(-120e3, 120e3))
def test_battery_current_solves_power(soc, p):
    i = bat.current_a(BA, soc, p)
    voc = bat.open_circuit_voltage_v(BA, soc)
    r = bat.resistance_ohm(BA, soc, p < 0)
    assert voc * i - r * i * i == np_approx(p)


def np_approx(x):
    import pytest
    return pytest.approx(x, rel=1e-9, abs=1e-6)


@fast
@given(socs)
def test_battery_limits_keep_soc_in_window(soc):
    p_dis, p_chg = bat.power_limits_w(BA, soc, 1.0)
    for p in (p_dis, -p_chg):
        current = bat.current_a(BA, soc, p)
        stored = current if current >= 0.0 else current * CFG.battery.coulombic_efficiency  # charge kept
        new = soc - stored / BA[bat.IDX.capacity_as]
        assert CFG.battery.soc_min - 1e-12 <= new <= CFG.battery.soc_max + 1e-12


step_inputs = st.tuples(
    socs, st.floats(-10.0, 90.0), st.floats(-0.3, 1.0), st.sampled_from([0.0, 1.0]),
    st.floats(-1.0, 1.0), st.floats(0.0, 35.0), st.floats(-2.0, 2.0), st.floats(-0.08, 0.08),
    st.floats(-10.0, 45.0), st.sampled_from([0.0, 0.01, 1.0]), st.floats(-5.0, 15.0), st.floats(-10.0, 10.0),
    st.floats(0.0, 5000.0), st.sampled_from([0.0, 1.0]))
MODELS = {"network": CFG, "paper_eqs": CFG.with_thermal_model("paper_eqs")}


def _rows(arr: np.ndarray) -> tuple[np.ndarray, ...]:
    """State, action, v0, v1, grade and conditions from rows of ``step_inputs``."""
    n = arr.shape[0]
    state = np.zeros((n, core.N_STATE))
    state[:, core.SOC], state[:, core.TEMP_C] = arr[:, 0], arr[:, 1]
    state[:, core.HEAT_X], state[:, core.CUTOFF] = arr[:, 2], arr[:, 3]
    state[:, core.HEAT_X_MIN] = -0.3
    state[:, core.WINDING_C] = arr[:, 1] - arr[:, 10]  # the winding above (or below) the housing
    state[:, core.COOLANT_C] = arr[:, 8] + arr[:, 11]
    cond = np.zeros((n, core.N_COND))
    cond[:, core.AMBIENT_C], cond[:, core.WATER_C], cond[:, core.COOLANT_FACTOR] = arr[:, 8], arr[:, 8] + 5.0, arr[:, 9]
    cond[:, core.PAYLOAD_KG], cond[:, core.FAN_FACTOR] = arr[:, 12], arr[:, 13]
    cond[:, core.ACCESSORY_W] = 7457.0
    v0 = arr[:, 5].copy()
    return state, arr[:, 4].copy(), v0, np.maximum(v0 + arr[:, 6], 0.0), arr[:, 7].copy(), cond


@settings(max_examples=300, deadline=None)
@given(step_inputs, st.sampled_from(sorted(MODELS)))
def test_step_invariants(inp, model):
    cfg = MODELS[model]
    phys = PhysicsCore(cfg)
    state, u, v0, v1, grade, cond = _rows(np.array([inp], dtype=float))
    new, out = phys.step(state, u, v0, v1, grade, cond)
    assert np.all(np.isfinite(new)) and np.all(np.isfinite(out))
    assert cfg.battery.soc_min - 1e-12 <= new[0, core.SOC] <= cfg.battery.soc_max + 1e-12
    assert 0.0 <= out[0, core.HEAT_INDEX] <= 1.0
    assert out[0, core.FUEL_G] >= 0.0
    assert out[0, core.MISSED_J] >= -1e-9 and out[0, core.BRAKE_POWER] >= -1e-9
    tm = out[0, core.MOTOR_TORQUE]
    # within the envelope, or (an empty battery) braking the shaft on the motor's own spinning loss
    assert abs(tm) <= max(out[0, core.MOTOR_AVAIL], 0.0) + 1e-9 or (out[0, core.MOTOR_MAX] < 0.0
                                                                and tm <= out[0, core.MOTOR_MAX] + 1e-9)
    # the heat-index floor follows the motor's new temperature
    assert new[0, core.HEAT_X_MIN] == -thm.pwm_initial(phys.th, new[0, core.TEMP_C])
    assert new[0, core.HEAT_X] >= new[0, core.HEAT_X_MIN]
    # never colder than the coolest heat sink (minus a small tolerance)
    temp, amb, cf = state[0, core.TEMP_C], cond[0, core.AMBIENT_C], cond[0, core.COOLANT_FACTOR]
    if model == "paper_eqs":
        sink = min(temp, amb, amb + 5.0 if cf > 0 and temp > cfg.thermal.thermostat_temp_c else temp)
    else:  # backward Euler on a conductance network: a maximum principle holds (the heat input is >= 0)
        sink = min(temp, amb, state[0, core.WINDING_C], state[0, core.COOLANT_C])
        assert min(new[0, core.WINDING_C], new[0, core.COOLANT_C]) >= sink - 1e-6
    assert new[0, core.TEMP_C] >= sink - 1e-6
    # energy balance of the step
    e_in = out[0, core.ENGINE_POWER] + out[0, core.BATT_CHEM]
    e_out = (out[0, core.WHEEL_POWER] + out[0, core.BRAKE_POWER] + out[0, core.BATT_LOSS] + out[0, core.MOTOR_LOSS]
             + out[0, core.CLUTCH_LOSS] + out[0, core.DRIVELINE_LOSS] + out[0, core.ACC])
    assert e_in == np_approx(e_out) or abs(e_in - e_out) < 1e-6 * max(abs(e_in), 1.0)


@settings(max_examples=50, deadline=None)
@given(st.lists(step_inputs, min_size=2, max_size=12), st.sampled_from(sorted(MODELS)))
def test_vectorised_equals_single(rows, model):
    phys = PhysicsCore(MODELS[model])
    state, u, v0, v1, g, cond = _rows(np.array(rows, dtype=float))
    nb, ob = phys.step(state, u, v0, v1, g, cond)
    for i in range(len(rows)):
        s1, o1 = phys.step(state[i:i + 1].copy(), u[i:i + 1].copy(), v0[i:i + 1].copy(), v1[i:i + 1].copy(),
                           g[i:i + 1].copy(), cond[i:i + 1].copy())
        np.testing.assert_array_equal(s1[0], nb[i])
        np.testing.assert_array_equal(o1[0], ob[i])


def test_initial_state_from_conditions():
    phys = PhysicsCore(CFG)
    s = phys.initial_state(Conditions(initial_motor_temp_c=45.0), 3)
    assert np.all(s[:, core.HEAT_X] == s[:, core.HEAT_X_MIN])
    assert np.all(s[:, core.HEAT_X] == -thm.pwm_initial(TH, 45.0))
