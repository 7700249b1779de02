"""The calibration protocol's physics checks (docs/calibration/protocol.md, §3): C6, a hard launch's winding rise
from the physics core against an independent integration of the network written here, and C1, Fig. 4 from eq 9
with the paper's constants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hev_thermal_env.physics import ThermalParams, paper_bus
from hev_thermal_env.physics import thermal as thm
from tools.paper import measure

SIGMA = 5.67e-8
#: Core (backward Euler, 1 s, conductances at the start of the step) against the fine integration below.
RISE_TOL_K = 0.3
#: The protocol's arithmetic (§1): +39 K for 30 s at 240 N·m from 15 K above the housing (G_w = 30 W/K).
PROTOCOL_RISE_K = 39.0


def _losses(cfg, torque_nm: float, speed_radps: float, housing_c: float) -> tuple[float, float, float]:
    """(winding, housing, inverter cold plate) heat in W, from the protocol's loss statement (§1): the combined map
    L = 1.05·(k_cu·T² + k_fe·ω^1.5 + k_fr·ω), the paper's derate η' = η − δ motoring (δ = 1 point per 15 °C above
    35 °C of the housing), the inverter's (1 − η_inv)·|P_dc| to the coolant; of the rest, the housing takes the mapped
    iron + friction loss in the share the motor keeps (1 − q_inv / loss) and the winding everything else: copper and
    the derate's extra current, as the vehicle step splits it."""
    mo, th = cfg.motor, cfg.thermal
    copper = mo.copper_loss_coeff * torque_nm ** 2
    core = mo.iron_loss_coeff * speed_radps ** 1.5 + mo.friction_loss_coeff * speed_radps
    mapped = (1.0 + th.extra_loss_frac) * (copper + core)
    p_mech = torque_nm * speed_radps
    delta = max(housing_c - th.derate_start_temp_c, 0.0) * th.derate_frac_per_c
    eta = p_mech / (p_mech + mapped) - delta
    p_dc = p_mech / eta
    loss = p_dc - p_mech
    q_inv = (1.0 - th.inverter_efficiency) * abs(p_dc)
    q_housing = (loss - q_inv) / loss * (1.0 + th.extra_loss_frac) * core
    return loss - q_inv - q_housing, q_housing, q_inv


def _derivatives(cfg, temps: np.ndarray, torque_nm: float, speed_radps: float, speed_mps: float,
                 ambient_c: float) -> np.ndarray:
    """dT/dt of (winding, housing, coolant): C·dT/dt = losses − conductances (protocol §1), radiation in kelvin."""
    th = cfg.thermal
    t_w, t_h, t_c = temps
    q_w, q_h, q_inv = _losses(cfg, torque_nm, speed_radps, t_h)
    c_w = th.winding_heat_capacity_j_per_k
    c_h = th.mass_kg * th.cp_j_per_kgk - c_w
    mcp = th.coolant_flow_l_per_min / 60.0 * th.coolant_density_kg_per_l * th.coolant_cp_j_per_kgk
    c_c = th.coolant_volume_l * th.coolant_density_kg_per_l * th.coolant_cp_j_per_kgk \
        + th.coolant_loop_metal_heat_capacity_j_per_k
    h_air = (th.h_air_base + th.h_air_natural * (abs(t_h - ambient_c) / 1000.0) ** 0.25
             + th.h_air_forced * (speed_mps * 3.6 / th.air_ref_speed_kmh) ** th.air_speed_exponent)
    q_air = h_air * th.area_m2 * (t_h - ambient_c)
    q_rad = th.emissivity * SIGMA * th.area_m2 * ((t_h + 273.15) ** 4 - (ambient_c + 273.15) ** 4)
    g_jacket = mcp * (1.0 - math.exp(-th.jacket_ua_w_per_k / mcp))
    valve = min(max((t_c - th.thermostat_temp_c) / th.thermostat_band_k, 0.0), 1.0)
    fan = min(max((t_c - th.fan_on_temp_c) / th.fan_band_k, 0.0), 1.0)
    face = max(th.ram_air_frac * speed_mps, fan * th.fan_air_speed_mps, th.still_air_speed_mps)
    ua_rad = th.radiator_ua_w_per_k * (face / th.radiator_ref_air_speed_mps) ** th.radiator_air_exponent
    g_rad = valve * mcp * (1.0 - math.exp(-ua_rad / (valve * mcp))) if valve > 0.0 else 0.0
    g_w = th.winding_conductance_w_per_k
    return np.array([(q_w - g_w * (t_w - t_h)) / c_w,
                     (q_h + g_w * (t_w - t_h) - q_air - q_rad - g_jacket * (t_h - t_c)) / c_h,
                     (q_inv + g_jacket * (t_h - t_c) - g_rad * (t_c - ambient_c)) / c_c])


def _integrate(cfg, start: np.ndarray, torques: np.ndarray, speeds: np.ndarray, substeps: int = 20) -> np.ndarray:
    """RK4 with ``substeps`` per second, the torque and speed of each second held (the core's outputs)."""
    temps, h = start.astype(float).copy(), 1.0 / substeps
    out = [temps.copy()]
    for torque, w in zip(torques, speeds):
        def f(y: np.ndarray, torque: float = torque, w: float = w) -> np.ndarray:
            return _derivatives(cfg, y, torque, w, measure.LAUNCH_SPEED_MPS, measure.PAPER_CONDITIONS.ambient_temp_c)
        for _ in range(substeps):
            k1 = f(temps)
            k2 = f(temps + 0.5 * h * k1)
            k3 = f(temps + 0.5 * h * k2)
            k4 = f(temps + h * k3)
            temps = temps + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(temps.copy())
    return np.array(out)


@pytest.fixture(scope="module")
def launch():
    return measure.launch_run(paper_bus())


def test_c6_launch_winding_rise_matches_an_independent_integration(launch):
    cfg = paper_bus()
    start = np.array([launch["winding_c"][0], launch["housing_c"][0], launch["coolant_c"][0]])
    ref = _integrate(cfg, start, launch["torque_nm"], launch["speed_radps"])
    rise_core, rise_ref = launch["winding_rise_k"], ref[-1, 0] - ref[0, 0]
    rpm = launch["speed_radps"][0] * 30 / math.pi
    print(f"C6: {measure.LAUNCH_S} s at {launch['torque_nm'][0]:.1f} N·m, {rpm:.0f} "
          f"rpm from {launch['winding_c'][0]:.1f} °C (housing {launch['housing_c'][0]:.1f} °C, steady after "
          f"{launch['warm_s']:.0f} s at rated torque): winding +{rise_core:.2f} K (core), +{rise_ref:.2f} K "
          f"(independent)")
    assert rise_core == pytest.approx(rise_ref, abs=RISE_TOL_K)
    np.testing.assert_allclose(launch["winding_c"], ref[:, 0], atol=RISE_TOL_K)
    np.testing.assert_allclose(launch["housing_c"], ref[:, 1], atol=0.05)
    np.testing.assert_allclose(launch["coolant_c"], ref[:, 2], atol=0.05)
    # every second at the (magnet-corrected) peak torque, the heat index taken out
    peak = cfg.motor.peak_torque_nm * (1 - cfg.thermal.torque_temp_coeff_per_c * (launch["housing_c"][:-1] - 20))
    np.testing.assert_allclose(launch["torque_nm"], peak, rtol=1e-9)


def test_c6_the_rise_is_the_protocols_order(launch):
    """§1's arithmetic: +39 K with 240 N·m from 15 K above the housing; at the steady state the magnets' coefficient
    leaves ≈233 N·m (copper loss −5.6 %) and the winding starts ≈19 K above the housing, so ≈+36.5 K."""
    assert abs(launch["winding_rise_k"] - PROTOCOL_RISE_K) < 4.0
    assert 10.0 < launch["winding_over_housing_start_k"] < 25.0  # 447-560 W over G_w = 30 W/K
    assert launch["winding_c"].max() < paper_bus().thermal.winding_trip_temp_c


def test_c6_the_comparison_can_fail(launch):
    """The same integration with a copper loss 5 % higher is off by more than three tolerances."""
    cfg = paper_bus()
    wrong = cfg.replace(motor=cfg.motor.replace(copper_loss_coeff=cfg.motor.copper_loss_coeff * 1.05))
    start = np.array([launch["winding_c"][0], launch["housing_c"][0], launch["coolant_c"][0]])
    ref = _integrate(wrong, start, launch["torque_nm"], launch["speed_radps"])
    assert abs((ref[-1, 0] - ref[0, 0]) - launch["winding_rise_k"]) > 3 * RISE_TOL_K


def test_c1_fig4_from_eq9_with_the_papers_constants():
    """Eq 9 at twice the continuous torque from cold, T_s = 30 s, T_gain = 0.3, PWM_initial = 0.3: x = −0.3 +
    0.01·t exactly, so PWM leaves 0 at 30 s and reaches 1 at 130 s."""
    th = ThermalParams(t_gain_cold=0.3).pack()
    assert thm.t_gain(th, 20.0) == 0.3 and thm.pwm_initial(th, 20.0) == pytest.approx(0.3)
    curve = measure.fig4_curve()
    t = curve["time_s"]
    np.testing.assert_allclose(curve["pwm"], np.clip(-0.3 + 0.01 * t, 0.0, 1.0), atol=1e-12)
    assert (curve["pwm_leaves_zero_s"], curve["pwm_reaches_one_s"]) == (30.0, 130.0)
