"""The motor's rating (physics v2): constant operating points at the rated condition, heat alone and as shipped,
against an independent integration of the network that splits the losses as the vehicle step does."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

from hev_thermal_env.physics import paper_bus
from tools import rating as R

RPM = math.pi / 30.0
SIGMA = 5.67e-8


@pytest.fixture(scope="module")
def v2():
    return paper_bus()


@pytest.fixture(scope="module")
def point(v2):
    """The rated point: 80 N·m at the envelopes' corner, 3,581 rpm (30 kW)."""
    torque, rpm = R.rated_point(v2)
    assert torque == 80.0 and rpm == pytest.approx(3580.99, abs=0.01) and torque * rpm * RPM == pytest.approx(30e3)
    return torque, rpm


def independent_rhs(config, torque_nm: float, speed_rpm: float, ambient_c: float):
    """dT/dt of (winding, housing, coolant) written from the parameters alone (docs/thermal_model.md), the bus
    standing with the pump full and the fan as controlled."""
    mo, th = config.motor, config.thermal
    w = speed_rpm * RPM
    f = 1.0 + th.extra_loss_frac
    core = f * (mo.iron_loss_coeff * w ** 1.5 + mo.friction_loss_coeff * w)
    base = f * mo.copper_loss_coeff * torque_nm ** 2 + core
    mcp = th.coolant_flow_l_per_min / 60.0 * th.coolant_density_kg_per_l * th.coolant_cp_j_per_kgk
    c_w = th.winding_heat_capacity_j_per_k
    c_h = th.mass_kg * th.cp_j_per_kgk - c_w
    c_c = th.coolant_volume_l * th.coolant_density_kg_per_l * th.coolant_cp_j_per_kgk \
        + th.coolant_loop_metal_heat_capacity_j_per_k

    def rhs(_t, y):
        t_w, t_h, t_c = y
        d = max(t_h - th.derate_start_temp_c, 0.0) * th.derate_frac_per_c
        u = torque_nm * w
        v = u + base
        p_elec = u * v / (u - d * v) if u > 0.0 else v  # η' = η₀ − δ (every loaded point here has η₀ > 50 %)
        loss = p_elec - u
        q_inv = (1.0 - th.inverter_efficiency) * abs(p_elec)
        heat = loss - q_inv
        q_h = heat / loss * core
        q_w = heat - q_h
        g_air = (th.h_air_base + th.h_air_natural * (abs(t_h - ambient_c) / 1000.0) ** 0.25) * th.area_m2
        q_rad = th.emissivity * SIGMA * th.area_m2 * ((t_h + 273.15) ** 4 - (ambient_c + 273.15) ** 4)
        g_jacket = mcp * (1.0 - math.exp(-th.jacket_ua_w_per_k / mcp))
        valve = min(max((t_c - th.thermostat_temp_c) / th.thermostat_band_k, 0.0), 1.0)
        fan = min(max((t_c - th.fan_on_temp_c) / th.fan_band_k, 0.0), 1.0)
        face = max(th.still_air_speed_mps, fan * th.fan_air_speed_mps)
        ua = th.radiator_ua_w_per_k * (face / th.radiator_ref_air_speed_mps) ** th.radiator_air_exponent
        g_rad = valve * mcp * (1.0 - math.exp(-ua / (valve * mcp))) if valve > 0.0 else 0.0
        q_wh = th.winding_conductance_w_per_k * (t_w - t_h)
        q_hc = g_jacket * (t_h - t_c)
        return [(q_w - q_wh) / c_w,
                (q_h + q_wh - g_air * (t_h - ambient_c) - q_rad - q_hc) / c_h,
                (q_inv + q_hc - g_rad * (t_c - ambient_c)) / c_c]

    return rhs


@pytest.mark.parametrize("ambient_c", [20.0, 40.0])
def test_steady_state_matches_an_independent_solution(v2, point, ambient_c):
    cond = R.OperatingCondition(ambient_c=ambient_c)
    got = R.steady_state(v2, *point, cond)
    rhs = independent_rhs(v2, *point, ambient_c)
    want = fsolve(lambda y: rhs(0.0, y), [got["winding_c"] + 3, got["housing_c"] + 3, got["coolant_c"] + 3],
                  xtol=1e-12)
    assert np.allclose([got["winding_c"], got["housing_c"], got["coolant_c"]], want, atol=0.05), (got, want)


def test_rated_transient_matches_an_independent_integration(v2, point):
    """Heat alone, 30 kW at the base speed in 40 °C air from cold for two hours: the backward-Euler network at 1 s
    against scipy's adaptive integration of the same equations."""
    run = R.hold(v2, *point, 7200, R.RATED)
    sol = solve_ivp(independent_rhs(v2, *point, 40.0), (0.0, 7200.0), [40.0, 40.0, 40.0],
                    t_eval=np.arange(1.0, 7201.0), max_step=5.0, rtol=1e-8, atol=1e-8)
    for i, node in enumerate(("winding_c", "housing_c", "coolant_c")):
        assert np.max(np.abs(run[node] - sol.y[i])) < 1.0, node


def test_thirty_kilowatts_settle_within_80_to_100_percent_of_the_allowed_rise(v2, point):
    """The rating: at the rated condition heat alone the governing limit's rise is 80-100 % of the allowed rise."""
    node, share = R.rise_share(v2, R.steady_state(v2, *point, R.RATED), R.RATED.ambient_c)
    assert node == "housing_c"
    assert 0.80 <= share <= 1.0, share


def test_what_the_motor_holds_by_heat_alone(v2, point):
    """More than its rating in 40 °C (it settles below the limit), more still in the paper's 20 °C air, and the
    held torque's steady state sits at the limit."""
    hot, cool = R.RATED, R.OperatingCondition(ambient_c=20.0)
    r40, r20 = R.held_power_ratio(v2, condition=hot), R.held_power_ratio(v2, condition=cool)
    assert 1.0 <= r40 < r20 <= 2.5
    t = R.held_torque_nm(v2, point[1], hot)
    _, share = R.rise_share(v2, R.steady_state(v2, t, point[1], hot), hot.ambient_c)
    assert 0.98 <= share <= 1.0


def test_as_shipped_the_heat_index_caps_an_overload_before_the_heat_does(v2, point):
    """Twice the continuous torque from the paper's 20 °C: eq 8 brings the torque down to the continuous envelope
    (times the magnets' factor) and the motor is never cut off; at the rated point nothing is capped."""
    run = R.hold(v2, 160.0, 3000.0, 1800, R.OperatingCondition(ambient_c=20.0), heat_index=True)
    assert run["torque_nm"][0] == pytest.approx(160.0)
    assert run["torque_nm"][-1] <= 80.0 + 1e-6
    assert run["housing_c"].max() < v2.thermal.cutoff_temp_c
    rated = R.hold(v2, *point, 3 * 3600, R.RATED, heat_index=True)
    assert rated["housing_c"].max() < v2.thermal.cutoff_temp_c
    assert rated["torque_nm"].min() >= 80.0 * (1.0 - v2.thermal.torque_temp_coeff_per_c * 50.0)


def test_spinning_losses_alone_release_the_motor_in_the_paper_conditions(v2):
    """At 20 °C with the cooling intact the spinning motor settles below the cut-off's release at every speed."""
    cond = R.OperatingCondition(ambient_c=20.0)
    for rpm in (2000.0, 4000.0, 6000.0):
        assert R.spinning_steady_c(v2, rpm, cond) < v2.thermal.cutoff_release_temp_c


def test_the_derate_against_copper_resistance(v2, point):
    """At the rated point the paper's derate adds more heat than R(T) would; at a low-speed launch far less."""
    s = R.steady_state(v2, *point, R.RATED)
    rated = R.derate_against_resistance(v2, *point, s["winding_c"], s["housing_c"])
    assert rated["derate_w"] > 2.0 * rated["resistance_w"] > 0.0
    launch = R.derate_against_resistance(v2, 240.0, 1000.0, s["winding_c"], s["housing_c"])
    assert launch["derate_w"] < 0.5 * launch["resistance_w"]


def test_physics_v1_is_kept_and_an_unknown_version_is_refused():
    assert paper_bus() == paper_bus(physics=2)
    v1 = paper_bus(physics=1).thermal
    assert (v1.jacket_ua_w_per_k, v1.radiator_ua_w_per_k) == (250.0, 175.0)
    assert paper_bus().thermal.jacket_ua_w_per_k == pytest.approx(3000.0 * 0.4273)
    with pytest.raises(ValueError, match="physics"):
        paper_bus(physics=3)
