"""Permanent-magnet synchronous traction motor (paper Table 1) with a loss-model efficiency map.

Table 1 swaps the rated and peak power; read correctly: rated 30 kW, peak 90 kW, base/max speed 3600/6000 rpm, peak
torque 240 N·m, hence 80 N·m continuous below base speed and constant power above; both envelopes corner at 90 kW /
240 N·m = 30 kW / 80 N·m = 375 rad/s, 3,581 rpm (Table 1 rounds it), and are 0 above the maximum speed, so a derated
motor (eq 8 blends them) never gets more torque than a cold one.

Losses (motor + inverter): P_loss = k_cu·T² + k_fe·ω^1.5 + k_fr·ω; the defaults give ≈95 % peak efficiency and a
shape close to ADVISOR's UQM PowerPhase 100 map scaled to 90 kW (``tests/test_physics.py``). Thermal effects: the
paper's 5 % extra loss and the derate δ (one efficiency point per 15 °C above 35 °C). With L = (1 + extra)·P_loss:
generating, P_elec = T·ω + L + δ·|T·ω|; motoring, P_elec = T·ω/η' with η' = η₀ − δ·s(η₀/0.5), s = 1 above 1 and
the smoothstep x²(3 − 2x) below: exactly δ wherever η₀ ≥ 50 % (every loaded point), fading out so that the loss
stays finite and continuous at zero torque (docs/thermal_model.md). The loss is always P_elec − T·ω.
"""

from __future__ import annotations

import dataclasses
import math

from .jit import jit
from .params import RPM, Layout, Params, Slot, spec

#: Efficiency below which the temperature derate fades out (motoring), η_k.
DERATE_KNEE_EFF = 0.5
#: Newton iterations of the motoring torque limit under a derate (from a close start, quadratically).
_NEWTON_ITERS = 3


@dataclasses.dataclass(frozen=True)
class MotorParams(Params):
    """Traction PMSM of the paper (Table 1)."""

    peak_torque_nm: float = spec(240.0, "peak torque below base speed (Table 1)", min=0.0)
    continuous_torque_nm: float = spec(80.0, "continuous (rated) torque below base speed: 30 kW at 3,581 rpm",
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
        for what in ("torque_nm", "power_w"):
            self.require(getattr(self, "continuous_" + what) <= getattr(self, "peak_" + what), "continuous_" + what,
                         f"must not exceed peak_{what}")

    @property
    def base_speed_rpm(self) -> float:
        return self.peak_power_w / self.peak_torque_nm / RPM


LAYOUT = MotorParams.LAYOUT = Layout.of_fields(MotorParams, replace={
    "max_speed_rpm": Slot("max_speed_radps", fill=lambda p: p.max_speed_rpm * RPM, fields=("max_speed_rpm",)),
}, unpacked=("mass_kg",))  # the mass belongs to the thermal model
IDX = LAYOUT.index()


@jit
def peak_torque_nm(mo, speed_radps):
    """Peak torque envelope: constant to base speed, then constant power; 0 beyond max speed."""
    w = abs(speed_radps)
    if w > mo[IDX.max_speed_radps] * (1.0 + 1e-9) or mo[IDX.enabled] == 0.0:
        return 0.0
    if w * mo[IDX.peak_torque_nm] <= mo[IDX.peak_power_w]:
        return mo[IDX.peak_torque_nm]
    return mo[IDX.peak_power_w] / w


@jit
def continuous_torque_nm(mo, speed_radps):
    """Continuous torque envelope (T_cont(ω) of eq 8): constant to base speed, constant power above,
    0 beyond the maximum speed like the peak envelope."""
    w = abs(speed_radps)
    over = w > mo[IDX.max_speed_radps] * (1.0 + 1e-9) or mo[IDX.enabled] == 0.0
    t = (mo[IDX.continuous_torque_nm] if w * mo[IDX.continuous_torque_nm] <= mo[IDX.continuous_power_w]
         else mo[IDX.continuous_power_w] / w)
    return 0.0 if over else t


@jit
def base_loss_w(mo, torque_nm, speed_radps):
    """Copper + iron + friction loss of the untouched (thermal-model-off) motor."""
    if mo[IDX.enabled] == 0.0:
        return 0.0
    w = abs(speed_radps)
    return (mo[IDX.copper_loss_coeff] * torque_nm * torque_nm + mo[IDX.iron_loss_coeff] * w * math.sqrt(w)
            + mo[IDX.friction_loss_coeff] * w)


@jit
def core_loss_w(mo, speed_radps):
    """Iron + friction part of :func:`base_loss_w` (heats the stator and housing, not the winding)."""
    if mo[IDX.enabled] == 0.0:
        return 0.0
    w = abs(speed_radps)
    return mo[IDX.iron_loss_coeff] * w * math.sqrt(w) + mo[IDX.friction_loss_coeff] * w


@jit
def _derated_loss_w(p_mech, loss, derate):
    """Loss P_elec − T·ω under the derate: motoring T·ω/η' − T·ω, generating L + δ·|T·ω|. With u = T·ω, v = u + L
    and K = η_k: above the knee P = u·v/(u − δ·v); below it P = K³v³/(K³v² − δ·u·(3K·v − 2u)), so
    P − u = L + v·δ·u·(3K·v − 2u)/(K³v² − δ·u·(3K·v − 2u))."""
    if p_mech <= 0.0:
        return loss - derate * p_mech
    u = p_mech
    v = p_mech + loss
    if u >= DERATE_KNEE_EFF * v:  # η₀ ≥ η_k: η' = η₀ − δ
        return u * (loss + derate * v) / (u - derate * v)
    k = DERATE_KNEE_EFF
    q = derate * u * (3.0 * k * v - 2.0 * u)
    den = k * k * k * v * v - q
    return loss + v * q / den if den > 0.0 else loss  # den underflows only where the power is ~0


@jit
def total_loss_w(mo, torque_nm, speed_radps, extra_frac, derate_frac):
    """Loss including the thermal model's extra loss fraction and efficiency derate: P_elec − T·ω."""
    if mo[IDX.enabled] == 0.0:
        return 0.0
    loss = (1.0 + extra_frac) * base_loss_w(mo, torque_nm, speed_radps)
    if derate_frac <= 0.0:
        return loss
    return _derated_loss_w(torque_nm * speed_radps, loss, derate_frac)


@jit
def electric_power_w(mo, torque_nm, speed_radps, extra_frac, derate_frac):
    """Electrical input power (negative when generating), with the extra loss and the derate."""
    if mo[IDX.enabled] == 0.0:
        return 0.0
    return torque_nm * speed_radps + total_loss_w(mo, torque_nm, speed_radps, extra_frac, derate_frac)


@jit
def torque_limits_for_power(mo, speed_radps, p_dis_max_w, p_chg_max_w, extra_frac, derate_frac, t_cap_nm):
    """Torque range [t_lo, t_hi] whose electrical power stays within [-p_chg_max_w, p_dis_max_w].

    Without a derate both sides are quadratics in T; motoring with one, P_elec(T) = T·ω/η' is solved by Newton's
    method from just above the root. Where the exact power at ``t_cap_nm`` (the envelope the motor cannot exceed
    anyway) is within the limit, t_hi is that start without iterating: t_hi is exact wherever it is below the cap.
    When even zero torque needs more than ``p_dis_max_w`` (the spinning motor's loss, an empty battery), t_hi < 0:
    the motor brakes the shaft to cover its own loss, and the battery never gives energy it does not have.
    """
    w = abs(speed_radps)
    f = 1.0 + extra_frac
    # the packed vector is read here only, the solve takes scalars (speed rule in jit.py: it is not inlined)
    return _torque_limits(f * mo[IDX.copper_loss_coeff],
                          f * (mo[IDX.iron_loss_coeff] * w * math.sqrt(w) + mo[IDX.friction_loss_coeff] * w), w,
                          p_dis_max_w, p_chg_max_w, derate_frac, t_cap_nm)


@jit
def _upper_root(a, b, c):
    """The larger root of a·T² + b·T + c = 0 for a > 0, or the vertex −b/(2a) where there is none; −c/b if a = 0."""
    if not a > 0.0:
        return -c / b
    disc = b * b - 4.0 * a * c
    return -b / (2.0 * a) if disc < 0.0 else (-b + math.sqrt(disc)) / (2.0 * a)


@jit
def _torque_limits(a, c0, w, p_dis_max_w, p_chg_max_w, derate_frac, t_cap_nm):
    """:func:`torque_limits_for_power` on scalars: P_loss = a·T² + c0 at speed ``w``."""
    b = w * (1.0 - derate_frac)  # generating: a T² + b T + c0 + p = 0 at electrical power −p
    if c0 > p_dis_max_w and w > 0.0:
        # the drag that covers the loss beyond p_dis: the larger (negative) root, or the vertex
        t_drag = _upper_root(a, b, c0 - p_dis_max_w)
        return min(_upper_root(a, b, c0 + p_chg_max_w), t_drag), t_drag
    # motoring side: a T² + w(1 + d) T + c0 - p_dis = 0, positive root: exact without a derate; with one, the
    # root of the loss L + d·T·ω, a little above the exact root (the exact loss is larger), which Newton's
    # method then reaches from above in two steps (the error ~d²/100 squares twice)
    c = c0 - p_dis_max_w
    b1 = w * (1.0 + derate_frac)
    if a > 0.0:
        t_hi = (-b1 + math.sqrt(b1 * b1 - 4.0 * a * c)) / (2.0 * a)
    elif w > 0.0:
        t_hi = -c / b1
    else:
        t_hi = 1e12
    binds = True
    if derate_frac > 0.0 and t_hi > t_cap_nm > 0.0:  # does the exact power at the cap stay within the limit?
        u = t_cap_nm * w
        binds = u + _derated_loss_w(u, a * t_cap_nm * t_cap_nm + c0, derate_frac) > p_dis_max_w
    if derate_frac > 0.0 and w > 1e-6 and t_hi > 1e-9 and binds:
        t_hi = _derated_motoring_limit(t_hi, a, c0, w, p_dis_max_w, derate_frac)
    # generating side: allowed T >= the larger root, never beyond the vertex where more braking torque would
    # return less power
    t_lo = _upper_root(a, b, c0 + p_chg_max_w) if (a > 0.0 or b > 0.0) else -1e12
    return min(t_lo, 0.0), max(t_hi, 0.0)


@jit
def _derated_motoring_limit(t_hi, a, c0, w, p_dis_max_w, d):
    """The torque where the derated P_elec = T·ω/η' (:func:`_derated_loss_w`'s two branches) reaches
    ``p_dis_max_w``: Newton's method from ``t_hi``, just above it."""
    k = DERATE_KNEE_EFF
    k3 = k * k * k
    for _ in range(_NEWTON_ITERS):
        u = t_hi * w
        v = u + a * t_hi * t_hi + c0
        dv = w + 2.0 * a * t_hi
        if u >= k * v:  # P = u·v/(u − δ·v)
            num = u * v
            den = u - d * v
            dnum = w * v + u * dv
            dden = w - d * dv
        else:  # P = K³v³/(K³v² − δ·u·(3K·v − 2u))
            num = k3 * v * v * v
            den = k3 * v * v - d * u * (3.0 * k * v - 2.0 * u)
            dnum = 3.0 * k3 * v * v * dv
            dden = 2.0 * k3 * v * dv - d * (3.0 * k * (w * v + u * dv) - 4.0 * u * w)
        # Newton on P = num/den: T -= (num/den − p)/P' with P' = (dnum·den − num·dden)/den², one division
        slope = dnum * den - num * dden
        if not (slope > 0.0 and den > 0.0):
            break
        t_hi = max(t_hi - (num - p_dis_max_w * den) * den / slope, 0.0)
    return t_hi
