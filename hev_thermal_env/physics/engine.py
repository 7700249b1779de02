"""Diesel engine: maximum torque curve and a parametric fuel-rate surface.

Fuel rate, a Willans-type surface in speed ω [rad/s] and brake power P [kW]: fuel_gps = c0 + c1·ω + c2·ω²
+ (c3 + c4·ω)·P + c5·P², a least-squares fit to ADVISOR's FC_CI119 (6.5 L, 119 kW) fuel map (2.1 % RMS, 5.1 % max
error over its 54 points: ``tests/test_physics.py::test_engine_fit_against_advisor``). The constant and speed terms
give the fuel at zero load (idle, motoring with accessories only). Fuel is cut on overrun (no positive torque asked
while the shaft turns above idle) and zero with the engine off.

Below the map (measured from 1,000 to 3,500 rpm and 120 to 420 N·m), at idle (700 rpm), with the accessories alone
(7.5 kW ≈ 100 N·m at 700 rpm) and in light city traction, the fuel is the surface's unchecked extrapolation: 0.25 g/s
(1.1 L/h) idling unloaded, 0.67 g/s (322 g/kWh) idling with the 7.5 kW accessories, 0.21 g/s at 1,000 rpm unloaded. It
rises with power everywhere there (c3 + c4·ω > 0 up to the maximum speed), so no load point below the map is free.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .jit import jit
from .params import RPM, Layout, Params, Slot, spec

MAX_CURVE = 12


@dataclasses.dataclass(frozen=True)
class EngineParams(Params):
    """Diesel engine, default calibrated to ADVISOR FC_CI119."""

    idle_speed_rpm: float = spec(700.0, "idle speed", min=100.0)
    max_speed_rpm: float = spec(3500.0, "maximum speed (top of the FC_CI119 map)", min=500.0)
    fuel_lhv_j_per_g: float = spec(43000.0, "fuel lower heating value (ADVISOR diesel)", min=1000.0)
    fuel_density_kg_per_l: float = spec(0.835, "diesel density for L/100 km", min=0.5, max=1.2)
    fuel_coeffs: tuple = spec((0.467811, -4.06548e-3, 1.55914e-5, 5.52159e-2, -1.54977e-6, 4.18751e-5),
                              "fuel-rate surface c0..c5 (g/s with ω in rad/s, P in kW), fit to FC_CI119")
    max_torque_speed_rpm: tuple = spec((700.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0, 3500.0),
                                       "speeds of the full-load curve (FC_CI119, idle point extrapolated)", min=0.0)
    max_torque_nm: tuple = spec((250.0, 310.0, 380.0, 400.0, 392.0, 368.0, 330.0),
                                "full-load torque at those speeds (FC_CI119)", min=0.0)

    def validate(self) -> None:
        s, t = self.max_torque_speed_rpm, self.max_torque_nm
        self.require(len(self.fuel_coeffs) == 6, "fuel_coeffs", "need 6 coefficients")
        self.require(len(s) == len(t), "max_torque_nm", "length differs from max_torque_speed_rpm")
        self.require(2 <= len(t) <= MAX_CURVE, "max_torque_nm", f"need 2 to {MAX_CURVE} points")
        self.require(all(a < b for a, b in zip(s, s[1:])), "max_torque_speed_rpm", "must increase")
        self.require(self.max_speed_rpm > self.idle_speed_rpm, "max_speed_rpm", "must exceed idle_speed_rpm")

    @property
    def max_power_w(self) -> float:
        return max(s * RPM * t for s, t in zip(self.max_torque_speed_rpm, self.max_torque_nm))


LAYOUT = EngineParams.LAYOUT = Layout.of_fields(EngineParams, replace={
    "idle_speed_rpm": Slot("idle_speed_radps", fill=lambda p: p.idle_speed_rpm * RPM, fields=("idle_speed_rpm",)),
    "max_speed_rpm": Slot("max_speed_radps", fill=lambda p: p.max_speed_rpm * RPM, fields=("max_speed_rpm",)),
    "fuel_coeffs": Slot("fuel_coeffs", 6),
    "max_torque_speed_rpm": (
        Slot("n_curve", fill=lambda p: len(p.max_torque_nm), fields=()),
        Slot("curve_speed_radps", MAX_CURVE, fill=lambda p: np.asarray(p.max_torque_speed_rpm) * RPM,
             fields=("max_torque_speed_rpm",))),
    "max_torque_nm": Slot("max_torque_nm", MAX_CURVE),
}, derived={"max_power_w": lambda p: p.max_power_w})  # speeds in rad/s, the full-load curve padded
IDX = LAYOUT.index()


@jit
def max_torque_nm(en, speed_radps):
    """Full-load torque at ``speed_radps`` (linear in the table, flat beyond its ends, 0 above max speed)."""
    if speed_radps > en[IDX.max_speed_radps] * (1.0 + 1e-9):
        return 0.0
    n = int(en[IDX.n_curve])
    s0 = IDX.curve_speed_radps
    t0 = IDX.max_torque_nm
    if speed_radps <= en[s0]:
        return en[t0]
    for k in range(1, n):
        if speed_radps <= en[s0 + k]:
            f = (speed_radps - en[s0 + k - 1]) / (en[s0 + k] - en[s0 + k - 1])
            return en[t0 + k - 1] + f * (en[t0 + k] - en[t0 + k - 1])
    return en[t0 + n - 1]


@jit
def fuel_rate_gps(en, speed_radps, torque_nm):
    """Fuel rate of the running engine at brake torque ``torque_nm`` ≥ 0 (idle fuel at zero torque)."""
    w = speed_radps
    p_kw = max(torque_nm, 0.0) * w * 1e-3
    c = IDX.fuel_coeffs
    rate = (en[c] + en[c + 1] * w + en[c + 2] * w * w + (en[c + 3] + en[c + 4] * w) * p_kw + en[c + 5] * p_kw * p_kw)
    return max(rate, 0.0)
