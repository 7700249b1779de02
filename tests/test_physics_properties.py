"""Property tests (hypothesis) on each physics component and on the batched step."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hev_thermal_env.physics import Conditions, PhysicsCore, paper_bus
from hev_thermal_env.physics import battery as bat
from hev_thermal_env.physics import core as C
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
def test_motor_power_limits_respected(w, p_dis, p_chg, derate):
    t_lo, t_hi = mot.torque_limits_for_power(MO, w, p_dis, p_chg, 0.05, derate)
    assert t_lo <= 0.0 <= t_hi
    if t_hi > 0:
        assert mot.electric_power_w(MO, t_hi, w, 0.05, derate) <= p_dis * (1 + 1e-9) + 1e-6
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
    assert gli.road_force_n(GL, vh, a, 0.0) >= gli.road_force_n(GL, vl, a, 0.0)
    assert gli.road_force_n(GL, vl, a, gh) >= gli.road_force_n(GL, vl, a, gl_)


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
        new = soc - bat.current_a(BA, soc, p) / BA[bat.CAPACITY_AS]
        assert CFG.battery.soc_min - 1e-12 <= new <= CFG.battery.soc_max + 1e-12


step_inputs = st.tuples(
    socs, st.floats(-10.0, 90.0), st.floats(-0.3, 1.0), st.sampled_from([0.0, 1.0]),
    st.floats(-1.0, 1.0), st.floats(0.0, 35.0), st.floats(-2.0, 2.0), st.floats(-0.08, 0.08),
    st.floats(-10.0, 45.0), st.sampled_from([0.0, 0.01, 1.0]))


@settings(max_examples=300, deadline=None)
@given(step_inputs)
def test_step_invariants(inp):
    soc, temp, hx, cut, u, v0, dv, grade, amb, cf = inp
    v1 = max(v0 + dv, 0.0)
    phys = PhysicsCore(CFG)
    state = np.array([[soc, temp, hx, -0.3, cut]])
    cond = np.array([[amb, amb + 5.0, cf]])
    new, out = phys.step(state, np.array([u]), np.array([v0]), np.array([v1]), np.array([grade]), cond)
    assert np.all(np.isfinite(new)) and np.all(np.isfinite(out))
    assert CFG.battery.soc_min - 1e-12 <= new[0, C.SOC] <= CFG.battery.soc_max + 1e-12
    assert 0.0 <= out[0, C.HEAT_INDEX] <= 1.0
    assert out[0, C.FUEL_G] >= 0.0
    assert out[0, C.MISSED_J] >= -1e-9 and out[0, C.BRAKE_POWER] >= -1e-9
    assert abs(out[0, C.MOTOR_TORQUE]) <= max(out[0, C.MOTOR_AVAIL], 0.0) + 1e-9
    # never colder than the coolest heat sink (minus a small tolerance)
    sink = min(temp, amb, amb + 5.0 if cf > 0 and temp > CFG.thermal.thermostat_temp_c else temp)
    assert new[0, C.TEMP_C] >= sink - 1e-6
    # energy balance of the step
    e_in = out[0, C.ENGINE_POWER] + out[0, C.BATT_CHEM]
    e_out = (out[0, C.WHEEL_POWER] + out[0, C.BRAKE_POWER] + out[0, C.BATT_LOSS] + out[0, C.MOTOR_LOSS]
             + out[0, C.CLUTCH_LOSS] + out[0, C.DRIVELINE_LOSS] + out[0, C.ACC])
    assert e_in == np_approx(e_out) or abs(e_in - e_out) < 1e-6 * max(abs(e_in), 1.0)


@settings(max_examples=50, deadline=None)
@given(st.lists(step_inputs, min_size=2, max_size=12))
def test_vectorised_equals_single(rows):
    phys = PhysicsCore(CFG)
    n = len(rows)
    arr = np.array(rows, dtype=float)
    state = np.column_stack([arr[:, 0], arr[:, 1], arr[:, 2], np.full(n, -0.3), arr[:, 3]])
    u, v0 = arr[:, 4].copy(), arr[:, 5].copy()
    v1 = np.maximum(v0 + arr[:, 6], 0.0)
    g = arr[:, 7].copy()
    cond = np.column_stack([arr[:, 8], arr[:, 8] + 5.0, arr[:, 9]])
    nb, ob = phys.step(state, u, v0, v1, g, cond)
    for i in range(n):
        s1, o1 = phys.step(state[i:i + 1].copy(), u[i:i + 1].copy(), v0[i:i + 1].copy(), v1[i:i + 1].copy(),
                           g[i:i + 1].copy(), cond[i:i + 1].copy())
        np.testing.assert_array_equal(s1[0], nb[i])
        np.testing.assert_array_equal(o1[0], ob[i])


def test_initial_state_from_conditions():
    phys = PhysicsCore(CFG)
    s = phys.initial_state(Conditions(initial_motor_temp_c=45.0), 3)
    assert np.all(s[:, C.HEAT_X] == s[:, C.HEAT_X_MIN])
    assert np.all(s[:, C.HEAT_X] == -thm.pwm_initial(TH, 45.0))
