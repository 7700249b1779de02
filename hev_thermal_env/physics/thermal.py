"""The motor's thermal parameters and effects: the paper's eqs 1-10, for both thermal models.

``ThermalParams.model`` selects the temperature model, both stepped by ``thermal_network.thermal_step``:
``"network"`` (the default; winding, housing, coolant loop, calibrated to the paper's figures, which the literal
model cannot show: its h_water·A = 1282 W/K with a perfect radiator clamps the motor at the 35 °C thermostat) or
``"paper_eqs"``, the paper's one node as written: m·c_p·dT/dt = Q_gen − Q_air − Q_rad − Q_cool (eq 7) with
Q_air = h_air·A·(T − T_amb) (eq 1), h_air = 6 + 6·(ΔT/1000)^0.25 + 60·(V/48.27)^0.63 with V in km/h (eq 4, the
documented form; ADVISOR's code feeds half the speed in m/s against 30), Q_cool = h_water·A·(T − T_water) above
the thermostat (eq 5, T_water held) and Q_rad = ε·σ·A·(T⁴ − T_amb⁴) in kelvin (eq 6).

Heat index (eqs 8-9): dx/dt = (T_gain/T_s)·(|T_out|/T_cont(ω) − 1), PWM = clip(x, 0, 1), available torque
T_cont·PWM + T_peak·(1 − PWM) ≤ T_peak, x held in [−PWM_initial(T), 1]; eq 10's T_gain and PWM_initial are our
linear ramps in the motor temperature. Efficiency derate −1 point per 15 °C above 35 °C (``motor.py``), cutoff at
70 °C until cooled to 60 °C; ``enabled=False`` is ADVISOR's unmodified motor (the paper's baseline). Fields whose
doc starts with "fitted:" hold the values of ``python -m hev_thermal_env.calibration``. Sources and rationale:
docs/thermal_model.md.
"""

from __future__ import annotations

import dataclasses
import math

from .jit import jit
from .layout import Layout, Slot
from .params import ConfigError, Params, spec

SIGMA = 5.67e-8
KELVIN = 273.15

#: Thermal models by name; the packed ``model`` slot holds the index.
THERMAL_MODELS = ("paper_eqs", "network")
MODEL_NETWORK = 1.0


@dataclasses.dataclass(frozen=True)
class ThermalParams(Params):
    """Motor thermal model (paper's node or lumped network), heat index and protection of the traction motor.

    Fields marked "fitted" are calibrated to the paper's figures (module docstring).
    """

    model: str = spec("network", "thermal model: 'network' (motor + coolant loop + radiator, calibrated) or "
                                 "'paper_eqs' (the paper's one-node eqs 1-7 as written)")
    enabled: bool = spec(True, "thermal effects on (derate, extra loss, cutoff); False = unmodified ADVISOR motor")
    # --- the motor node (paper Table 1, eqs 1-7) ---
    mass_kg: float = spec(100.0, "thermal mass of the motor (Table 1)", min=0.0, min_exclusive=True)
    cp_j_per_kgk: float = spec(430.0, "specific heat (Table 1)", min=0.0, min_exclusive=True)
    area_m2: float = spec(0.4273, "cooling area (Table 1; ADVISOR 0.4·(m/91)^0.7)", min=0.0, min_exclusive=True)
    h_water_w_per_m2k: float = spec(3000.0, "coolant heat-transfer coefficient (paper eq 5; paper_eqs model)",
                                    min=0.0)
    thermostat_temp_c: float = spec(35.0, "coolant flows above this motor temperature (paper)")
    emissivity: float = spec(0.9, "radiation emissivity (paper eq 6)", min=0.0, max=1.0)
    cutoff_temp_c: float = spec(70.0, "the motor stops at this temperature (paper)")
    cutoff_release_temp_c: float = spec(60.0, "the motor runs again once cooled to this (hysteresis)")
    derate_start_temp_c: float = spec(35.0, "efficiency derate starts above this temperature (paper)")
    derate_frac_per_c: float = spec(0.01 / 15.0, "efficiency points lost per °C above the start (paper: 1 per 15 °C)",
                                    min=0.0, max=0.1)
    extra_loss_frac: float = spec(0.05, "extra heat as a fraction of losses: noise, friction (paper: 5 %)",
                                  min=0.0, max=1.0)
    torque_temp_coeff_per_c: float = spec(
        0.001873, "fitted: fraction of the torque envelopes lost per °C above torque_ref_temp_c (magnet "
                  "remanence: NdFeB flux −0.126 %/K (paper); the paper's Prius data −0.32 %/K of peak torque)",
        min=0.0, max=0.0032)
    torque_ref_temp_c: float = spec(20.0, "temperature of the unmodified (cold) torque envelopes (magnet data: 20 °C)")
    # --- heat index, eqs 8-10 ---
    t_s_s: float = spec(30.0, "T_s of eq 9: longest run time at peak torque (paper)", min=0.0, min_exclusive=True)
    t_gain_cold: float = spec(
        0.1105, "fitted: T_gain at and below t_gain_temp_lo_c (paper: T_gain in [0.1, 0.3])",
        min=0.1, max=0.3)
    t_gain_hot: float = spec(
        0.2742, "fitted: T_gain at and above t_gain_temp_hi_c (paper: T_gain in [0.1, 0.3])",
        min=0.1, max=0.3)
    t_gain_temp_lo_c: float = spec(
        35.05, "fitted: temperature where T_gain starts to rise (from the 20 °C start to 10 K above the paper's "
               "35 °C, where its torque and efficiency corrections start)",
        min=20.0, max=45.0)
    t_gain_temp_hi_c: float = spec(
        35.79, "fitted: temperature where T_gain reaches t_gain_hot (at most the 70 °C cutoff)",
        min=25.0, max=70.0)
    pwm_initial_cold: float = spec(
        0.5792, "fitted: PWM_initial up to pwm_initial_temp_lo_c, the cold overload reserve: from the paper's 0.3 "
                "up to 0.6, the reserve for 30 s at peak torque (the paper's HEV motor) at the highest T_gain 0.3",
        min=0.3, max=0.6)
    pwm_initial_temp_lo_c: float = spec(
        38.51, "fitted: the full cold reserve holds up to this temperature (from the paper's 20 °C start to 5 K "
               "above its 35 °C thermostat)",
        min=20.0, max=40.0)
    pwm_initial_temp_hi_c: float = spec(
        63.47, "fitted: temperature where the overload reserve PWM_initial reaches 0 (from 10 K above the "
               "paper's start up to the 70 °C cutoff)",
        min=30.0, max=70.0)
    # --- air convection, eq 4 ---
    h_air_base: float = spec(6.0, "eq 4: still-air coefficient W/(m²·K)", min=0.0)
    h_air_natural: float = spec(6.0, "eq 4: natural convection term at ΔT = 1000 K", min=0.0)
    h_air_forced: float = spec(60.0, "eq 4: forced convection at the reference speed", min=0.0)
    air_ref_speed_kmh: float = spec(48.27, "eq 4: reference air speed", min=0.0, min_exclusive=True)
    air_speed_exponent: float = spec(0.63, "eq 4: speed exponent", min=0.0)
    # --- the network: winding, housing, coolant loop, thermostat, radiator, fan (thermal_network.py) ---
    winding_heat_capacity_j_per_k: float = spec(
        3384.0, "fitted: heat capacity of the winding node (copper 8-15 kg at 385 J/(kg·K), with insulation and "
                "resin); the housing node holds the rest of Table 1's m·c_p",
        min=2500.0, max=10000.0)
    winding_conductance_w_per_k: float = spec(
        536.7, "fitted: winding-to-housing conductance through the slot insulation (the winding 1-30 K above "
               "the housing at the continuous copper loss of 624 W)",
        min=20.0, max=600.0)
    jacket_conductance_w_per_k: float = spec(
        482.4, "fitted: housing-to-coolant conductance, valve fully open; at most the paper's h_water·A = "
               "1282 W/K (whole cooling area wetted), at least 100 W/K (a 2 kW loss 20 K above the coolant)",
        min=100.0, max=1282.0)
    thermostat_band_k: float = spec(
        5.63, "fitted: proportional band of the thermostat valve: closed at thermostat_temp_c, fully open this "
              "much above (wax thermostats: 2-12 K)",
        min=2.0, max=12.0)
    coolant_heat_capacity_j_per_k: float = spec(
        62810.0, "fitted: coolant loop heat capacity: 4-20 L of 50 % glycol (3.5 kJ/(kg·K)) plus radiator and "
                 "pump metal",
        min=15e3, max=80e3)
    radiator_ua_w_per_k: float = spec(
        335.5, "fitted: radiator conductance at the reference face air speed (a low-temperature radiator for a "
               "30 kW-continuous motor: 2-4 kW at 10-40 K)",
        min=50.0, max=600.0)
    radiator_ref_air_speed_mps: float = spec(5.0, "face air speed at which radiator_ua_w_per_k holds (design "
                                                  "point of automotive radiators, 3-8 m/s)",
                                             min=1.0, max=10.0)
    radiator_air_exponent: float = spec(0.7, "UA ∝ (face air speed)^n: air-side Nusselt ∝ Re^0.6-0.8",
                                        min=0.5, max=0.9)
    ram_air_frac: float = spec(0.25, "face air speed per unit vehicle speed (ram air; a bus's side or rear "
                                     "cooling pack sees 0.1-0.5)", min=0.1, max=0.5)
    still_air_speed_mps: float = spec(0.5, "equivalent face air speed at standstill with the fan off (natural "
                                           "draught)", min=0.0, max=1.0)
    fan_air_speed_mps: float = spec(4.0, "face air speed the fan gives at full speed (2-6 m/s)", min=2.0, max=6.0)
    fan_on_temp_c: float = spec(40.0, "the fan starts at this coolant temperature (5 K above the valve)",
                                min=0.0, max=100.0)
    fan_band_k: float = spec(5.0, "the fan reaches full speed this much above fan_on_temp_c", min=0.5, max=20.0)

    def validate(self) -> None:
        if self.model not in THERMAL_MODELS:
            raise ConfigError(f"ThermalParams.model: {self.model!r} is not one of {list(THERMAL_MODELS)}")
        if self.cutoff_release_temp_c >= self.cutoff_temp_c:
            raise ConfigError("ThermalParams.cutoff_release_temp_c: must be below cutoff_temp_c")
        if self.t_gain_temp_hi_c <= self.t_gain_temp_lo_c:
            raise ConfigError("ThermalParams.t_gain_temp_hi_c: must exceed t_gain_temp_lo_c")
        if self.pwm_initial_temp_hi_c <= self.pwm_initial_temp_lo_c:
            raise ConfigError("ThermalParams.pwm_initial_temp_hi_c: must exceed pwm_initial_temp_lo_c")
        if self.winding_heat_capacity_j_per_k >= 0.5 * self.heat_capacity_j_per_k:
            raise ConfigError("ThermalParams.winding_heat_capacity_j_per_k: must be below half the motor's m·c_p")
        if self.model == "paper_eqs":
            # the paper's node is integrated explicitly: its fastest time constant must exceed the step
            tau = self.mass_kg * self.cp_j_per_kgk / max(self.h_water_w_per_m2k * self.area_m2, 1e-12)
            if tau < 2.0:
                raise ConfigError(f"ThermalParams.h_water_w_per_m2k: thermal time constant {tau:.2f} s is below "
                                  "2 s, too stiff for the 1 s step")

    @property
    def heat_capacity_j_per_k(self) -> float:
        """Heat capacity of the motor node, m·c_p."""
        return self.mass_kg * self.cp_j_per_kgk


LAYOUT = ThermalParams.LAYOUT = Layout.of_fields(ThermalParams, replace={
    "model": Slot("model", fill=lambda p: float(THERMAL_MODELS.index(p.model))),
}, derived={
    # constants of the per-row code, computed once here (the kernel has ~100 ns per row; a division is ~5)
    "motor_heat_capacity_j_per_k": lambda p: p.mass_kg * p.cp_j_per_kgk,
    "housing_heat_capacity_j_per_k": lambda p: p.mass_kg * p.cp_j_per_kgk - p.winding_heat_capacity_j_per_k,
    "eps_sigma_area": lambda p: p.emissivity * SIGMA * p.area_m2,
    "h_water_area_w_per_k": lambda p: p.h_water_w_per_m2k * p.area_m2,
    "inv_valve_band_per_k": lambda p: 1.0 / p.thermostat_band_k,
    "inv_fan_band_per_k": lambda p: 1.0 / p.fan_band_k,
    "inv_radiator_ref_air_speed": lambda p: 1.0 / p.radiator_ref_air_speed_mps,
    "air_speed_per_mps": lambda p: 3.6 / p.air_ref_speed_kmh,
    "ram_air_per_mps": lambda p: p.ram_air_frac / p.radiator_ref_air_speed_mps,
    "still_air_term": lambda p: (p.still_air_speed_mps / p.radiator_ref_air_speed_mps) ** p.radiator_air_exponent,
    "tgain_slope_per_c": lambda p: (p.t_gain_hot - p.t_gain_cold) / (p.t_gain_temp_hi_c - p.t_gain_temp_lo_c),
    "pwm0_slope_per_c": lambda p: -p.pwm_initial_cold / (p.pwm_initial_temp_hi_c - p.pwm_initial_temp_lo_c),
    "inv_t_s": lambda p: 1.0 / p.t_s_s,
})
"""Packed thermal parameters: one slot per field, in field order (the model as its index), then derived constants."""
IDX = LAYOUT.index()


@jit
def _ramp(x, x_lo, x_hi, y_lo, slope):
    """y_lo up to x_lo, then rising with ``slope`` to x_hi, constant beyond (slope precomputed: no division)."""
    return y_lo + slope * (min(max(x, x_lo), x_hi) - x_lo)


@jit
def pwm_initial(th, temp_c):
    """PWM_initial, the overload reserve, of a motor at ``temp_c`` (our eq 10 companion)."""
    return _ramp(temp_c, th[IDX.pwm_initial_temp_lo_c], th[IDX.pwm_initial_temp_hi_c], th[IDX.pwm_initial_cold],
                 th[IDX.pwm0_slope_per_c])


@jit
def heat_index_floor(th, temp_c):
    """Anti-windup floor of the heat-index integrator: −PWM_initial at the motor's present temperature."""
    return -pwm_initial(th, temp_c)


@jit
def t_gain(th, temp_c):
    """T_gain = f(T_mc) (eq 10), linear between the cold and hot values."""
    return _ramp(temp_c, th[IDX.t_gain_temp_lo_c], th[IDX.t_gain_temp_hi_c], th[IDX.t_gain_cold],
                 th[IDX.tgain_slope_per_c])


@jit
def derate_frac(th, temp_c):
    """Efficiency points lost (as a fraction) at ``temp_c``; 0 with the model off."""
    d = max(temp_c - th[IDX.derate_start_temp_c], 0.0) * th[IDX.derate_frac_per_c]
    return d if th[IDX.enabled] != 0.0 else 0.0


@jit
def torque_factor(th, temp_c):
    """Share of the cold torque envelopes a motor at ``temp_c`` can give (magnet remanence); 1 with the model off."""
    k = 1.0 - max(temp_c - th[IDX.torque_ref_temp_c], 0.0) * th[IDX.torque_temp_coeff_per_c]
    return max(k, 0.0) if th[IDX.enabled] != 0.0 else 1.0


@jit
def extra_loss_frac(th):
    """The extra heat as a fraction of the losses; 0 with the model off."""
    extra = th[IDX.extra_loss_frac]
    return extra if th[IDX.enabled] != 0.0 else 0.0


@jit
def heat_index_pwm(heat_x):
    """PWM = clip(x, 0, 1) (eq 9)."""
    return min(max(heat_x, 0.0), 1.0)


@jit
def available_torque_nm(th, peak_nm, cont_nm, heat_x, cutoff):
    """Torque limit under the heat index (eq 8) and the cutoff, never above the peak; the peak with the model off."""
    pwm = heat_index_pwm(heat_x)
    blended = min(cont_nm * pwm + peak_nm * (1.0 - pwm), peak_nm)
    limited = 0.0 if cutoff != 0.0 else blended
    # one return (speed rule in jit.py)
    return limited if th[IDX.enabled] != 0.0 else peak_nm


@jit
def heat_index_step(th, heat_x, heat_x_min, torque_nm, cont_nm, temp_c, dt_s):
    """One Euler step of eq 9 with anti-windup to [heat_x_min, 1]; T_gain at ``temp_c``.

    Beyond the maximum speed the continuous envelope is 0 and the motor gives no torque: the
    overload ratio is then taken as 0 (the index relaxes).
    """
    ratio = abs(torque_nm) / cont_nm if cont_nm > 0.0 else 0.0
    dx = t_gain(th, temp_c) * th[IDX.inv_t_s] * (ratio - 1.0)
    return min(max(heat_x + dx * dt_s, heat_x_min), 1.0)


@jit
def forced_air_term(air_speed_per_mps, v_exp, speed_mps):
    """(V/48.27)^0.63 of eq 4 (V in km/h); ``air_speed_per_mps`` = 3.6 / 48.27. 0 at standstill."""
    v_rel = max(speed_mps, 0.0) * air_speed_per_mps
    return v_rel ** v_exp if v_rel > 0.0 else 0.0


@jit
def air_conductance_core(h_still0, h_natural, h_forced, forced_term, area, temp_c, ambient_c):
    """h_air·A of eqs 1 and 4 (W/K) from scalars, the speed's term precomputed (:func:`forced_air_term`)."""
    h_still = h_still0 + h_natural * math.sqrt(math.sqrt(abs(temp_c - ambient_c) * 1e-3))
    return (h_still + h_forced * forced_term) * area


@jit
def paper_node_core(g_air, eps_sigma_area, h_water_area, thermostat_c, temp_c, ambient_c, water_c, coolant_factor):
    """(Q_air, Q_rad, Q_cool) of the paper's node (eqs 1, 5, 6) from scalars; ``g_air`` = h_air·A."""
    q_air = g_air * (temp_c - ambient_c)
    q_cool = h_water_area * coolant_factor * (temp_c - water_c) if (temp_c > thermostat_c
                                                                   and coolant_factor > 0.0) else 0.0
    tk = temp_c + KELVIN
    ta = ambient_c + KELVIN
    q_rad = eps_sigma_area * ((tk * tk) * (tk * tk) - (ta * ta) * (ta * ta))
    return q_air, q_rad, q_cool


@jit
def heat_flows_w(th, temp_c, ambient_c, water_c, coolant_factor, speed_mps):
    """(Q_air, Q_rad, Q_cool) leaving the paper's node at ``temp_c`` and the vehicle speed (eqs 1, 4, 5, 6)."""
    term = forced_air_term(th[IDX.air_speed_per_mps], th[IDX.air_speed_exponent], speed_mps)
    g_air = air_conductance_core(th[IDX.h_air_base], th[IDX.h_air_natural], th[IDX.h_air_forced], term,
                                 th[IDX.area_m2], temp_c, ambient_c)
    return paper_node_core(g_air, th[IDX.eps_sigma_area], th[IDX.h_water_area_w_per_k], th[IDX.thermostat_temp_c],
                           temp_c, ambient_c, water_c, coolant_factor)


@jit
def temperature_step(th, temp_c, heat_w, ambient_c, water_c, coolant_factor, speed_mps, dt_s):
    """One Euler step of the paper's eq 7. Returns (new temperature, Q_air, Q_rad, Q_cool)."""
    q_air, q_rad, q_cool = heat_flows_w(th, temp_c, ambient_c, water_c, coolant_factor, speed_mps)
    new = temp_c + dt_s * (heat_w - q_air - q_rad - q_cool) / th[IDX.motor_heat_capacity_j_per_k]
    return new, q_air, q_rad, q_cool


@jit
def cutoff_step(th, cutoff, temp_c):
    """Protection with hysteresis: trips at cutoff_temp_c, releases at cutoff_release_temp_c."""
    # one return, not three (speed rule in jit.py)
    tripped = temp_c >= th[IDX.cutoff_temp_c] or (cutoff != 0.0 and temp_c > th[IDX.cutoff_release_temp_c])
    return 1.0 if (th[IDX.enabled] != 0.0 and tripped) else 0.0
