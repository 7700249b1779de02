"""Permanent-magnet synchronous traction motor (paper Table 1) with a loss-model efficiency map.

Table 1 swaps the rated and peak power; read correctly: rated 30 kW, peak 90 kW, base/max speed
3600/6000 rpm, peak torque 240 N·m, hence continuous torque 80 N·m below base speed and constant
power above it.

Losses (motor + inverter), a function of torque T [N·m] and speed ω [rad/s]::

    P_loss = k_cu·T² + k_fe·ω^1.5 + k_fr·ω

copper ∝ T², iron ∝ ω^1.5, friction and windage ∝ ω. The defaults give a peak efficiency of
≈95 % and an efficiency shape close to ADVISOR's UQM PowerPhase 100 map scaled to 90 kW
(``tests/test_physics.py`` checks the peak and the shape). Electrical power is
``P_elec = T·ω + P_loss_total``; the thermal model adds its extra losses on top (``thermal.py``):
``P_loss_total = (1 + extra)·P_loss + derate·|T·ω|``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .jit import jit
from .layout import Layout, Slot
from .params import ConfigError, Params, spec

RPM = math.pi / 30.0



@dataclasses.dataclass(frozen=True)
class MotorParams(Params):
    """Traction PMSM of the paper (Table 1)."""

    peak_torque_nm: float = spec(240.0, "peak torque below base speed (Table 1)", min=0.0)
    continuous_torque_nm: float = spec(80.0, "continuous (rated) torque below base speed: 30 kW at 3600 rpm",
                                       min=0.0, min_exclusive=True)
    peak_power_w: float = spec(90e3, "peak power (Table 1, swapped)", min=0.0)
    continuous_power_w: float = spec(30e3, "rated power (Table 1, swapped)", min=0.0, min_exclusive=True)
    max_speed_rpm: float = spec(6000.0, "maximum speed (Table 1)", min=100.0)
    copper_loss_coeff: float = spec(0.0975, "k_cu in W/(N·m)²", min=0.0)
    iron_loss_coeff: float = spec(0.143, "k_fe in W/(rad/s)^1.5", min=0.0)
    friction_loss_coeff: float = spec(0.65, "k_fr in W/(rad/s)", min=0.0)
    mass_kg: float = spec(100.0, "motor mass (Table 1); the thermal node uses ThermalParams.mass_kg", min=0.0)
    enabled: bool = spec(True, "False removes the motor (conventional bus): no torque, no losses")

    def validate(self) -> None:
        if self.continuous_torque_nm > self.peak_torque_nm:
            raise ConfigError("MotorParams.continuous_torque_nm: must not exceed peak_torque_nm")
        if self.continuous_power_w > self.peak_power_w:
            raise ConfigError("MotorParams.continuous_power_w: must not exceed peak_power_w")

    @property
    def base_speed_rpm(self) -> float:
        return self.peak_power_w / self.peak_torque_nm / RPM

    def pack(self) -> np.ndarray:
        return LAYOUT.pack(self)


LAYOUT = Layout.of_fields(MotorParams, replace={
    "max_speed_rpm": Slot("max_speed_radps", fill=lambda p: p.max_speed_rpm * RPM, fields=("max_speed_rpm",)),
}, unpacked=("mass_kg",))
"""Packed motor parameters read by the kernels (the mass belongs to the thermal model)."""
PEAK_TORQUE = LAYOUT["peak_torque_nm"]
CONT_TORQUE = LAYOUT["continuous_torque_nm"]
PEAK_POWER = LAYOUT["peak_power_w"]
CONT_POWER = LAYOUT["continuous_power_w"]
MAX_RADPS = LAYOUT["max_speed_radps"]
K_CU = LAYOUT["copper_loss_coeff"]
K_FE = LAYOUT["iron_loss_coeff"]
K_FR = LAYOUT["friction_loss_coeff"]
ENABLED = LAYOUT["enabled"]


@jit
def peak_torque_nm(mo, speed_radps):
    """Peak torque envelope: constant to base speed, then constant power; 0 beyond max speed."""
    w = abs(speed_radps)
    if w > mo[MAX_RADPS] * (1.0 + 1e-9) or mo[ENABLED] == 0.0:
        return 0.0
    if w * mo[PEAK_TORQUE] <= mo[PEAK_POWER]:
        return mo[PEAK_TORQUE]
    return mo[PEAK_POWER] / w


@jit
def continuous_torque_nm(mo, speed_radps):
    """Continuous torque envelope (T_cont(ω) of eq 8); never zero so eq 9 stays finite."""
    w = abs(speed_radps)
    if w * mo[CONT_TORQUE] <= mo[CONT_POWER]:
        return mo[CONT_TORQUE]
    return mo[CONT_POWER] / w


@jit
def base_loss_w(mo, torque_nm, speed_radps):
    """Copper + iron + friction loss of the untouched (thermal-model-off) motor."""
    if mo[ENABLED] == 0.0:
        return 0.0
    w = abs(speed_radps)
    return mo[K_CU] * torque_nm * torque_nm + mo[K_FE] * w * math.sqrt(w) + mo[K_FR] * w


@jit
def total_loss_w(mo, torque_nm, speed_radps, extra_frac, derate_frac):
    """Loss including the thermal model's extra loss fraction and efficiency derate."""
    return (1.0 + extra_frac) * base_loss_w(mo, torque_nm, speed_radps) + derate_frac * abs(torque_nm * speed_radps)


@jit
def electric_power_w(mo, torque_nm, speed_radps, extra_frac, derate_frac):
    """Electrical input power (negative when generating)."""
    if mo[ENABLED] == 0.0:
        return 0.0
    return torque_nm * speed_radps + total_loss_w(mo, torque_nm, speed_radps, extra_frac, derate_frac)


@jit
def torque_limits_for_power(mo, speed_radps, p_dis_max_w, p_chg_max_w, extra_frac, derate_frac):
    """Torque range [t_lo, t_hi] whose electrical power stays within [-p_chg_max_w, p_dis_max_w].

    Solves the quadratic P_elec(T) = limit on each side of T = 0. Returns (0, 0) when even zero
    torque exceeds the discharge limit.
    """
    w = abs(speed_radps)
    f = 1.0 + extra_frac
    a = f * mo[K_CU]
    c0 = f * (mo[K_FE] * w * math.sqrt(w) + mo[K_FR] * w)
    if c0 > p_dis_max_w:
        return 0.0, 0.0
    # motoring side: a T² + w(1+d) T + c0 - p_dis = 0, positive root
    b = w * (1.0 + derate_frac)
    c = c0 - p_dis_max_w
    if a > 0.0:
        t_hi = (-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    elif b > 0.0:
        t_hi = -c / b
    else:
        t_hi = 1e12
    # generating side: a T² + w(1-d) T + c0 + p_chg = 0; allowed T >= larger root, and never
    # beyond the vertex where more braking torque would return less power
    b = w * (1.0 - derate_frac)
    c = c0 + p_chg_max_w
    if a > 0.0:
        vertex = -b / (2.0 * a)
        disc = b * b - 4.0 * a * c
        t_lo = vertex if disc < 0.0 else (-b + math.sqrt(disc)) / (2.0 * a)
    elif b > 0.0:
        t_lo = -c / b
    else:
        t_lo = -1e12
    return min(t_lo, 0.0), max(t_hi, 0.0)
