"""The motor at constant operating points: its continuous (S1) rating, and what it holds by heat alone.

The rating (docs/thermal_model.md, *The rated condition*, gives the numbers): 30 kW at the base speed
(:func:`rated_point`: 80 N·m at 3,581 rpm, where both torque envelopes corner; Table 1 rounds it to 3,600 rpm) in
40 °C air, IEC 60034-1's reference temperature of the final coolant (clause 8.2: 40 °C air for machines whose ultimate
coolant is the surrounding air), on a bench (:data:`RATED`: the bus standing, no ram air, the pump at full flow, the
fan as its controller runs it, full speed above 45 °C coolant). The governing limit is whichever protection a steady
state reaches first: the housing's 70 °C cut-off or the winding's own trip (class H, 165 °C); the allowed rise is that
limit less the 40 °C air.

:func:`hold` steps the thermal network fed by the loss split of the vehicle step at one torque and speed: *heat alone*
keeps the torque whatever the heat index (eqs 8-9) says and never trips, *as shipped* caps it by the heat index and the
protections as the vehicle step does.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from hev_thermal_env.physics import motor as mot
from hev_thermal_env.physics import thermal as thm
from hev_thermal_env.physics import thermal_network as tnet
from hev_thermal_env.physics.config import VehicleConfig


@dataclasses.dataclass(frozen=True)
class OperatingCondition:
    """Where a motor is held: air temperature, vehicle speed (ram air and eq 4's forced convection), pump flow share
    and fan. :data:`RATED` is the rating's bench."""

    ambient_c: float = 40.0
    vehicle_speed_mps: float = 0.0
    coolant_factor: float = 1.0
    fan_factor: float = 1.0


RATED = OperatingCondition()
"""IEC 60034-1's 40 °C reference air; the bus standing, pump full, fan as controlled."""


def rated_point(config: VehicleConfig) -> tuple[float, float]:
    """(torque N·m, speed rpm) of the continuous rating: the continuous torque at the speed where it meets the
    continuous power, the envelopes' corner (80 N·m at 3,581 rpm = 30 kW)."""
    mo = config.motor
    return mo.continuous_torque_nm, mo.continuous_power_w / mo.continuous_torque_nm / mot.RPM


def forced_air_term(air_speed_per_mps: float, v_exp: float, speed_mps: float) -> float:
    """(V/48.27)^0.63 of eq 4 (V in km/h); ``air_speed_per_mps`` = 3.6 / 48.27. 0 at standstill."""
    v_rel = max(speed_mps, 0.0) * air_speed_per_mps
    return float(v_rel ** v_exp) if v_rel > 0.0 else 0.0


def _speed_terms(th: np.ndarray, v_mps: float) -> tuple[float, float]:
    """eq 4's (V/48.27)^0.63 and the radiator's (ram air / reference)^n at vehicle speed ``v_mps``."""
    if v_mps <= 0.0:
        return 0.0, 0.0
    forced = forced_air_term(th[thm.IDX.air_speed_per_mps], th[thm.IDX.air_speed_exponent], v_mps)
    ram = (th[thm.IDX.ram_air_per_mps] * v_mps) ** th[thm.IDX.radiator_air_exponent]
    return forced, ram


def hold(config: VehicleConfig, torque_nm: float, speed_rpm: float, seconds: int,
         condition: OperatingCondition = RATED, *, start_c: float | tuple[float, float, float] | None = None,
         heat_index: bool = False, dt_s: float = 1.0) -> dict[str, np.ndarray]:
    """Hold the motor at ``torque_nm`` and ``speed_rpm`` for ``seconds`` (steps of ``dt_s``) from every node at
    ``start_c`` (default the air; or (winding, housing, coolant)). ``heat_index`` False: heat alone (the torque is
    held, nothing trips); True: as shipped (the torque capped by eq 8's available torque, the magnets' factor and the
    protections).

    Returns per step the torque given, the winding, housing and coolant temperatures after it (°C), the heat index's
    integrator x, and the winding, housing and inverter heat (W)."""
    mo, th = config.motor.pack(), config.thermal.pack()
    network = th[thm.IDX.model] == thm.MODEL_NETWORK
    w = speed_rpm * mot.RPM
    start = condition.ambient_c if start_c is None else start_c
    winding, housing, coolant = (float(t) for t in start) if isinstance(start, tuple) else (float(start),) * 3
    hx = thm.heat_index_floor(th, housing)
    cutoff = trip = 0.0
    forced, ram = _speed_terms(th, condition.vehicle_speed_mps)
    n = int(seconds / dt_s)
    names = ("torque_nm", "winding_c", "housing_c", "coolant_c", "heat_x", "q_winding_w", "q_housing_w", "q_inverter_w")
    out = {k: np.empty(n) for k in names}
    extra = thm.extra_loss_frac(th)
    for k in range(n):
        derate = thm.derate_frac(th, housing)
        torque = float(torque_nm)
        if heat_index:
            k_temp = thm.torque_factor(th, housing)
            avail = thm.available_torque_nm(th, k_temp * mot.peak_torque_nm(mo, w), k_temp * mot.continuous_torque_nm(
                mo, w), hx, 1.0 if (cutoff or trip) else 0.0)
            torque = min(torque, avail)
        loss = mot.total_loss_w(mo, torque, w, extra, derate)
        q_w, q_h, q_i, _ = tnet.split_loss_w(loss, torque * w + loss, (1.0 + extra) * mot.core_loss_w(mo, w),
                                             th[thm.IDX.inverter_efficiency], network)
        new_h, new_w, new_c = tnet.thermal_step(th, housing, winding, coolant, q_w, q_h, q_i, condition.ambient_c,
                                                coolant, condition.coolant_factor, condition.fan_factor, forced, ram,
                                                1.0 / dt_s)[:3]
        hx = thm.heat_index_step(th, hx, thm.heat_index_floor(th, new_h), torque, mot.continuous_torque_nm(mo, w),
                                 housing, dt_s)
        housing, winding, coolant = new_h, new_w, new_c
        if heat_index:
            cutoff = thm.cutoff_step(th, cutoff, housing)
            trip = thm.winding_trip_step(th, trip, winding)
        for key, val in zip(names, (torque, winding, housing, coolant, hx, q_w, q_h, q_i)):
            out[key][k] = val
    return out


def steady_state(config: VehicleConfig, torque_nm: float, speed_rpm: float,
                 condition: OperatingCondition = RATED, *, stop_above_limits: bool = False) -> dict[str, float] | None:
    """The heat-alone steady state at a constant point: the winding, housing and coolant temperatures (°C) once no
    node has moved more than 1 mK over the last simulated 10 minutes (steps of 2 s; the valve and the fan are set
    at each step's start, as in the vehicle step); ``ValueError`` if that takes more than 48 simulated hours.
    ``stop_above_limits``: None as soon as a node passes its protection's trip temperature."""
    state: tuple[float, float, float] | float = condition.ambient_c
    nodes = ("winding_c", "housing_c", "coolant_c")
    limits = limits_c(config)
    for _ in range(48):
        run = hold(config, torque_nm, speed_rpm, 3600, condition, start_c=state, dt_s=2.0)
        if stop_above_limits and any(float(run[k].max()) > limit for k, limit in limits.items()):
            return None
        state = tuple(float(run[k][-1]) for k in nodes)
        if max(float(np.ptp(run[k][-300:])) for k in nodes) < 1e-3:
            return dict(zip(nodes, state))
    raise ValueError(f"steady_state: no steady state at {torque_nm} N·m, {speed_rpm} rpm (last {state})")


def limits_c(config: VehicleConfig) -> dict[str, float]:
    """The two protections' trip temperatures (°C) by node."""
    return {"housing_c": config.thermal.cutoff_temp_c, "winding_c": config.thermal.winding_trip_temp_c}


def rise_share(config: VehicleConfig, state: dict[str, float], ambient_c: float) -> tuple[str, float]:
    """The governing node of a steady state and its rise as a share of the allowed rise (limit − air)."""
    shares = {node: (state[node] - ambient_c) / (limit - ambient_c) for node, limit in limits_c(config).items()}
    node = max(shares, key=shares.get)
    return node, shares[node]


def held_torque_nm(config: VehicleConfig, speed_rpm: float, condition: OperatingCondition = RATED,
                   tol_nm: float = 0.05) -> float:
    """The largest torque at ``speed_rpm`` whose heat-alone steady state stays within both protections (bisection;
    at most the peak envelope, 0 if the spinning motor's loss alone exceeds them)."""
    mo = config.motor.pack()
    hi = mot.peak_torque_nm(mo, speed_rpm * mot.RPM)

    def fits(t: float) -> bool:
        return steady_state(config, t, speed_rpm, condition, stop_above_limits=True) is not None

    if fits(hi):
        return hi
    if not fits(0.0):
        return 0.0
    lo = 0.0
    while hi - lo > tol_nm:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def held_power_ratio(config: VehicleConfig, speed_rpm: float | None = None,
                     condition: OperatingCondition = RATED) -> float:
    """What the motor holds by heat alone at ``speed_rpm`` (default the rated point's), over its continuous power."""
    rpm = rated_point(config)[1] if speed_rpm is None else speed_rpm
    return held_torque_nm(config, rpm, condition) * rpm * mot.RPM / config.motor.continuous_power_w


def spinning_steady_c(config: VehicleConfig, speed_rpm: float, condition: OperatingCondition) -> float:
    """The housing's steady temperature with the motor spinning at zero torque (°C): where it stays above the
    cut-off's release, no action brings a cut-off motor back."""
    return steady_state(config, 0.0, speed_rpm, condition)["housing_c"]


#: Copper's temperature coefficient of resistance at 20 °C (1/K; IEC 60028 annealed copper).
COPPER_ALPHA_PER_K = 0.00393


def derate_against_resistance(config: VehicleConfig, torque_nm: float, speed_rpm: float,
                              winding_c: float, housing_c: float) -> dict[str, float]:
    """The paper's efficiency derate against copper resistance rising with temperature, at one point: the heat the
    derate adds at the housing temperature (W, over the loss without it), and the heat R(T) would add instead, the
    copper loss at 20 °C (the mapped k_cu·T²) times α·(T_winding − 20 °C)."""
    mo, th = config.motor.pack(), config.thermal.pack()
    w = speed_rpm * mot.RPM
    extra = thm.extra_loss_frac(th)
    with_derate = mot.total_loss_w(mo, torque_nm, w, extra, thm.derate_frac(th, housing_c))
    without = mot.total_loss_w(mo, torque_nm, w, extra, 0.0)
    copper_w = config.motor.copper_loss_coeff * torque_nm ** 2
    return {"derate_w": with_derate - without, "resistance_w": copper_w * COPPER_ALPHA_PER_K * (winding_c - 20.0)}
