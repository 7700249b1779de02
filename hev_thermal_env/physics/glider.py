"""Glider and road load: the force the wheels must deliver to follow a speed trace.

Road load: F = m·a·(1 + f_rot) + m·g·Crr·cos(θ) + m·g·sin(θ) + ½·ρ·Cd·A·v², θ = atan(grade), m the test mass
(ADVISOR's 40-ft transit bus, VEH_RTS06 body and WH_HEAVY tyres, calibrated to the paper's Table 3) plus the run's
payload (``Conditions.payload_kg``: passengers on top of the test mass, which carries ADVISOR's 1.84 t of cargo).
"""

from __future__ import annotations

import dataclasses
import math

from .jit import jit
from .params import Layout, Params, spec


@dataclasses.dataclass(frozen=True)
class GliderParams(Params):
    """Body, tyres and air: everything the road load needs."""

    mass_kg: float = spec(15000.0, "vehicle test mass incl. powertrain and cargo (calibrated to Table 3)",
                          min=0.0, min_exclusive=True)
    rotating_mass_frac: float = spec(0.06, "equivalent rotating inertia as a fraction of mass", min=0.0, max=1.0)
    drag_coefficient: float = spec(0.79, "aerodynamic drag coefficient Cd (ADVISOR VEH_RTS06)", min=0.0, max=3.0)
    frontal_area_m2: float = spec(7.8965, "frontal area A (ADVISOR VEH_RTS06)", min=0.0, min_exclusive=True)
    rolling_resistance_coeff: float = spec(0.00938, "rolling resistance Crr (ADVISOR WH_HEAVY)", min=0.0, max=0.1)
    wheel_radius_m: float = spec(0.5, "tyre rolling radius (ADVISOR WH_HEAVY)", min=0.05, max=2.0)
    air_density_kgpm3: float = spec(1.23, "air density", min=0.5, max=2.0)
    gravity_mps2: float = spec(9.81, "gravitational acceleration", min=9.0, max=10.5)
    regen_driven_axle_frac_10mph: float = spec(0.5, "share of the braking the driven axle takes at 10 mph (ADVISOR "
                                               "WH_HEAVY wh_fa_dl_brake_frac)", min=0.4, max=0.7)
    regen_driven_axle_frac_60mph: float = spec(
        0.8, "share of the braking the driven axle takes at and above 60 mph (ADVISOR WH_HEAVY)", min=0.6, max=0.9)


LAYOUT = GliderParams.LAYOUT = Layout.of_fields(GliderParams)
IDX = LAYOUT.index()


@jit
def effective_mass_kg(gl, payload_kg):
    """Mass (test mass + payload) plus the equivalent mass of the rotating parts."""
    return (gl[IDX.mass_kg] + payload_kg) * (1.0 + gl[IDX.rotating_mass_frac])


@jit
def road_force_n(gl, speed_mps, accel_mps2, grade, payload_kg):
    """Total tractive force needed at the wheels (positive drives, negative brakes): inertia, then rolling + grade +
    aerodynamic force at ``speed_mps`` on ``grade`` (rise/run)."""
    m_g = (gl[IDX.mass_kg] + payload_kg) * gl[IDX.gravity_mps2]
    if grade == 0.0:
        cos_t, sin_t = 1.0, 0.0
    else:  # θ = atan(grade)
        inv = 1.0 / math.sqrt(1.0 + grade * grade)
        cos_t, sin_t = inv, grade * inv
    rolling = m_g * gl[IDX.rolling_resistance_coeff] * cos_t if speed_mps > 1e-3 else 0.0
    aero = 0.5 * gl[IDX.air_density_kgpm3] * gl[IDX.drag_coefficient] * gl[IDX.frontal_area_m2] * speed_mps * speed_mps
    return effective_mass_kg(gl, payload_kg) * accel_mps2 + (rolling + m_g * sin_t + aero)


MPH_10 = 10.0 * 0.44704
MPH_60 = 60.0 * 0.44704


@jit
def driven_axle_brake_frac(gl, speed_mps):
    """Share of the braking the driven axle takes, the rest on the other axle's friction brakes (ADVISOR WH_HEAVY):
    0 at standstill, linear to the 10 mph value, then linear to the 60 mph value, constant above."""
    f10 = gl[IDX.regen_driven_axle_frac_10mph]
    f60 = gl[IDX.regen_driven_axle_frac_60mph]
    v = max(speed_mps, 0.0)
    low = f10 * v / MPH_10
    high = f10 + (f60 - f10) * (min(v, MPH_60) - MPH_10) / (MPH_60 - MPH_10)
    return low if v < MPH_10 else high
