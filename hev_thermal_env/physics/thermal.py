"""The paper's motor thermal model (eqs 1-7), heat index (eqs 8-9) and protection.

One lumped node of mass m and heat capacity c_p (eq 7)::

    m·c_p·dT/dt = Q_gen − Q_air − Q_rad − Q_cool

* Q_gen: motor losses plus the paper's extra 5 % (noise, friction), ``extra_loss_frac``.
* Q_air = h_air·A·(T − T_amb) (eq 1) with h_air = 6 + 6·(ΔT/1000)^0.25 + 60·(V/48.27)^0.63
  (eq 4), V the vehicle speed in km/h. ADVISOR's code feeds half the speed in m/s against 30;
  we keep the paper's (and ADVISOR's documentation's) form.
* Q_cool = h_water·A·(T − T_water) (eq 5) when the motor is above the thermostat (35 °C). The
  paper assumes a perfect radiator (T_water back to its initial value); T_water is a condition
  of the run and h_water is scaled by the coolant mode (on 1, degraded < 1, off 0).
* Q_rad = ε·σ·A·(T⁴ − T_amb⁴) in kelvin (eq 6).

Heat index (eqs 8-9): an integrator x with dx/dt = (T_gain/T_s)·(|T_out|/T_cont(ω) − 1),
x(0) = −PWM_initial, held in [−PWM_initial, 1] (anti-windup); PWM = clip(x, 0, 1) and the
available torque is T_max = T_cont·PWM + T_peak·(1 − PWM).

Eq 10 (T_gain = f(T_mc)) is left open by the paper, which states only that T_gain lies in
[0.1, 0.3] in the vehicle simulation. Our choice: T_gain rises linearly from ``t_gain_cold``
at ``t_gain_temp_lo_c`` to ``t_gain_hot`` at ``t_gain_temp_hi_c`` (a hotter magnet loses its
overload reserve faster). PWM_initial "relates to the initial temperature": it falls linearly
from ``pwm_initial_cold`` at ``pwm_initial_temp_lo_c`` to 0 at ``pwm_initial_temp_hi_c``.

Efficiency derate: −1 percentage point per 15 °C above 35 °C (the paper's simulation, consistent
with eq 10's NdFeB remanence loss of ≈12.6 %/100 K), applied as an extra loss of that fraction of
the mechanical power. Protection: at ``cutoff_temp_c`` (70 °C) the motor stops (torque 0) until it
has cooled to ``cutoff_release_temp_c``.

With ``enabled=False`` the motor is ADVISOR's unmodified one (the paper's baseline): no derate,
no extra loss, no cutoff, peak torque always; temperature and heat index are still computed
and reported.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .jit import jit
from .layout import Layout
from .params import ConfigError, Params, spec

SIGMA = 5.67e-8
KELVIN = 273.15


@dataclasses.dataclass(frozen=True)
class ThermalParams(Params):
    """Lumped thermal node, heat index and protection of the traction motor."""

    enabled: bool = spec(True, "thermal effects on (derate, extra loss, cutoff); False = unmodified ADVISOR motor")
    mass_kg: float = spec(100.0, "thermal mass of the motor (Table 1)", min=0.0, min_exclusive=True)
    cp_j_per_kgk: float = spec(430.0, "specific heat (Table 1)", min=0.0, min_exclusive=True)
    area_m2: float = spec(0.4273, "cooling area (Table 1; ADVISOR 0.4·(m/91)^0.7)", min=0.0, min_exclusive=True)
    h_water_w_per_m2k: float = spec(3000.0, "coolant heat-transfer coefficient (paper)", min=0.0)
    thermostat_temp_c: float = spec(35.0, "coolant flows above this motor temperature (paper)")
    emissivity: float = spec(0.9, "radiation emissivity (paper eq 6)", min=0.0, max=1.0)
    cutoff_temp_c: float = spec(70.0, "the motor stops at this temperature (paper)")
    cutoff_release_temp_c: float = spec(60.0, "the motor runs again once cooled to this (hysteresis)")
    derate_start_temp_c: float = spec(35.0, "efficiency derate starts above this temperature (paper)")
    derate_frac_per_c: float = spec(0.01 / 15.0, "efficiency lost per °C above the start (1 point per 15 °C)",
                                    min=0.0, max=0.1)
    extra_loss_frac: float = spec(0.05, "extra heat as a fraction of losses: noise, friction (paper: 5 %)",
                                  min=0.0, max=1.0)
    t_s_s: float = spec(30.0, "T_s of eq 9: longest run time at peak torque", min=0.0, min_exclusive=True)
    t_gain_cold: float = spec(0.1, "T_gain at and below t_gain_temp_lo_c (eq 10 choice)", min=0.0, max=10.0)
    t_gain_hot: float = spec(0.3, "T_gain at and above t_gain_temp_hi_c (eq 10 choice)", min=0.0, max=10.0)
    t_gain_temp_lo_c: float = spec(35.0, "temperature where T_gain starts to rise")
    t_gain_temp_hi_c: float = spec(70.0, "temperature where T_gain reaches t_gain_hot")
    pwm_initial_cold: float = spec(0.3, "PWM_initial for a motor starting at or below pwm_initial_temp_lo_c",
                                   min=0.0, max=1.0)
    pwm_initial_temp_lo_c: float = spec(20.0, "start temperature giving pwm_initial_cold")
    pwm_initial_temp_hi_c: float = spec(70.0, "start temperature giving PWM_initial = 0")
    h_air_base: float = spec(6.0, "eq 4: still-air coefficient W/(m²·K)", min=0.0)
    h_air_natural: float = spec(6.0, "eq 4: natural convection term at ΔT = 1000 K", min=0.0)
    h_air_forced: float = spec(60.0, "eq 4: forced convection at the reference speed", min=0.0)
    air_ref_speed_kmh: float = spec(48.27, "eq 4: reference air speed", min=0.0, min_exclusive=True)
    air_speed_exponent: float = spec(0.63, "eq 4: speed exponent", min=0.0)

    def validate(self) -> None:
        if self.cutoff_release_temp_c >= self.cutoff_temp_c:
            raise ConfigError("ThermalParams.cutoff_release_temp_c: must be below cutoff_temp_c")
        if self.t_gain_temp_hi_c <= self.t_gain_temp_lo_c:
            raise ConfigError("ThermalParams.t_gain_temp_hi_c: must exceed t_gain_temp_lo_c")
        if self.pwm_initial_temp_hi_c <= self.pwm_initial_temp_lo_c:
            raise ConfigError("ThermalParams.pwm_initial_temp_hi_c: must exceed pwm_initial_temp_lo_c")
        tau = self.mass_kg * self.cp_j_per_kgk / max(self.h_water_w_per_m2k * self.area_m2, 1e-12)
        if tau < 2.0:
            raise ConfigError(f"ThermalParams.h_water_w_per_m2k: thermal time constant {tau:.2f} s is below "
                              "2 s, too stiff for the 1 s step")

    @property
    def heat_capacity_j_per_k(self) -> float:
        return self.mass_kg * self.cp_j_per_kgk

    def pack(self) -> np.ndarray:
        return LAYOUT.pack(self)


LAYOUT = Layout.of_fields(ThermalParams)
"""Packed thermal parameters: one slot per field, in field order."""
ENABLED = LAYOUT["enabled"]
MASS_KG = LAYOUT["mass_kg"]
CP = LAYOUT["cp_j_per_kgk"]
AREA_M2 = LAYOUT["area_m2"]
H_WATER = LAYOUT["h_water_w_per_m2k"]
THERMOSTAT_C = LAYOUT["thermostat_temp_c"]
EMISSIVITY = LAYOUT["emissivity"]
CUTOFF_C = LAYOUT["cutoff_temp_c"]
RELEASE_C = LAYOUT["cutoff_release_temp_c"]
DERATE_START_C = LAYOUT["derate_start_temp_c"]
DERATE_PER_C = LAYOUT["derate_frac_per_c"]
EXTRA_LOSS = LAYOUT["extra_loss_frac"]
T_S = LAYOUT["t_s_s"]
TGAIN_COLD = LAYOUT["t_gain_cold"]
TGAIN_HOT = LAYOUT["t_gain_hot"]
TGAIN_LO_C = LAYOUT["t_gain_temp_lo_c"]
TGAIN_HI_C = LAYOUT["t_gain_temp_hi_c"]
PWM0_COLD = LAYOUT["pwm_initial_cold"]
PWM0_LO_C = LAYOUT["pwm_initial_temp_lo_c"]
PWM0_HI_C = LAYOUT["pwm_initial_temp_hi_c"]
H_AIR0 = LAYOUT["h_air_base"]
H_AIR_NAT = LAYOUT["h_air_natural"]
H_AIR_FORCED = LAYOUT["h_air_forced"]
V_REF_KMH = LAYOUT["air_ref_speed_kmh"]
V_EXP = LAYOUT["air_speed_exponent"]


@jit
def _ramp(x, x_lo, x_hi, y_lo, y_hi):
    f = min(max((x - x_lo) / (x_hi - x_lo), 0.0), 1.0)
    return y_lo + f * (y_hi - y_lo)


@jit
def pwm_initial(th, initial_temp_c):
    """PWM_initial as a function of the motor's starting temperature (our eq 10 companion)."""
    return _ramp(initial_temp_c, th[PWM0_LO_C], th[PWM0_HI_C], th[PWM0_COLD], 0.0)


@jit
def t_gain(th, temp_c):
    """T_gain = f(T_mc) (eq 10), linear between the cold and hot values."""
    return _ramp(temp_c, th[TGAIN_LO_C], th[TGAIN_HI_C], th[TGAIN_COLD], th[TGAIN_HOT])


@jit
def derate_frac(th, temp_c):
    """Efficiency lost (as a fraction of mechanical power) at ``temp_c``; 0 with the model off."""
    if th[ENABLED] == 0.0:
        return 0.0
    return max(temp_c - th[DERATE_START_C], 0.0) * th[DERATE_PER_C]


@jit
def extra_loss_frac(th):
    return th[EXTRA_LOSS] if th[ENABLED] != 0.0 else 0.0


@jit
def heat_index_pwm(heat_x):
    """PWM = clip(x, 0, 1) (eq 9)."""
    return min(max(heat_x, 0.0), 1.0)


@jit
def available_torque_nm(th, peak_nm, cont_nm, heat_x, cutoff):
    """Torque limit under the heat index (eq 8) and the cutoff; the peak with the model off."""
    if th[ENABLED] == 0.0:
        return peak_nm
    if cutoff != 0.0:
        return 0.0
    pwm = heat_index_pwm(heat_x)
    return cont_nm * pwm + peak_nm * (1.0 - pwm)


@jit
def heat_index_step(th, heat_x, heat_x_min, torque_nm, cont_nm, temp_c, dt_s):
    """One Euler step of eq 9 with anti-windup to [x_min, 1]."""
    dx = t_gain(th, temp_c) / th[T_S] * (abs(torque_nm) / cont_nm - 1.0)
    return min(max(heat_x + dx * dt_s, heat_x_min), 1.0)


@jit
def heat_flows_w(th, temp_c, ambient_c, water_c, coolant_factor, speed_mps):
    """(Q_air, Q_rad, Q_cool) leaving the motor at ``temp_c`` (eqs 1, 4, 5, 6)."""
    dT = temp_c - ambient_c
    v_kmh = max(speed_mps, 0.0) * 3.6
    h_air = th[H_AIR0] + th[H_AIR_NAT] * math.sqrt(math.sqrt(abs(dT) / 1000.0))
    if v_kmh > 0.0:
        h_air += th[H_AIR_FORCED] * (v_kmh / th[V_REF_KMH]) ** th[V_EXP]
    q_cool = 0.0
    if temp_c > th[THERMOSTAT_C] and coolant_factor > 0.0:
        q_cool = th[H_WATER] * coolant_factor * th[AREA_M2] * (temp_c - water_c)
    q_air = h_air * th[AREA_M2] * dT
    tk = temp_c + KELVIN
    ta = ambient_c + KELVIN
    # ``th`` is read for the last time outside any branch (speed rule in jit.py)
    q_rad = th[EMISSIVITY] * SIGMA * th[AREA_M2] * ((tk * tk) * (tk * tk) - (ta * ta) * (ta * ta))
    return q_air, q_rad, q_cool


@jit
def temperature_step(th, temp_c, heat_w, ambient_c, water_c, coolant_factor, speed_mps, dt_s):
    """One Euler step of eq 7. Returns (new temperature, Q_air, Q_rad, Q_cool)."""
    q_air, q_rad, q_cool = heat_flows_w(th, temp_c, ambient_c, water_c, coolant_factor, speed_mps)
    new = temp_c + dt_s * (heat_w - q_air - q_rad - q_cool) / (th[MASS_KG] * th[CP])
    return new, q_air, q_rad, q_cool


@jit
def cutoff_step(th, cutoff, temp_c):
    """Protection with hysteresis: trips at cutoff_temp_c, releases at cutoff_release_temp_c."""
    # one return, not three (speed rule in jit.py)
    tripped = temp_c >= th[CUTOFF_C] or (cutoff != 0.0 and temp_c > th[RELEASE_C])
    return 1.0 if (th[ENABLED] != 0.0 and tripped) else 0.0
