"""Seeded stop-to-stop (micro-trip) generator of synthetic city-bus cycles.

A bus cycle is a chain of micro-trips, each starting and ending at standstill::

    dwell -> accelerate -> cruise (-> change speed -> cruise) -> brake to stop -> dwell -> ...

* Dwell times at stops are drawn uniformly from ``dwell_s_range``.
* Acceleration follows a bus traction curve: a constant limit ``max_accel_mps2`` at low speed
  and a power limit ``accel_power_w_per_kg / v`` above it, so it falls with speed. Each trip
  scales the curve by a driver factor drawn from ``accel_scale_range``.
* Cruise targets are drawn from a triangular distribution over ``cruise_speed_kmh_range`` with
  mode ``cruise_speed_mode_kmh`` (most trips slow, a few fast); during a cruise the speed
  follows the target plus a first-order autoregressive fluctuation of standard deviation
  ``speed_noise_kmh``, never above ``max_speed_kmh``. With probability ``speed_change_prob``
  a trip changes to a second cruise speed before stopping (traffic).
* Braking uses a per-trip deceleration drawn from ``decel_mps2_range``.
* Every change of acceleration is limited to ``max_jerk_mps3`` and speed targets are approached
  along a jerk-limited profile, so the speed is smooth and ends exactly at the target. Only the
  last step of an approach may exceed the jerk limit slightly, to land on the target.

The cycle lasts exactly ``round(duration_s)`` seconds and ends at standstill: a trip that would
overrun the remaining time is shortened (shorter cruise, then lower speed) and the remainder
becomes the final dwell. Speeds are rounded to 1e-6 m/s so a generated cycle written to CSV
reads back identically. The road is flat (grade 0).

The built-in ``beijing`` cycle is this generator with :data:`BEIJING_SEED` and
:data:`BEIJING_KWARGS`; it is synthetic, not a measured Beijing bus cycle. Hilly roads under
any cycle: :mod:`~hev_thermal_env.cycles.grades`.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .cycle import Cycle

#: Seed of the built-in synthetic ``beijing`` cycle.
BEIJING_SEED = 171

#: Keyword arguments (besides the seed) of the built-in synthetic ``beijing`` cycle.
BEIJING_KWARGS: dict[str, Any] = {"duration_s": 1300.0}

#: Targets of the synthetic ``beijing`` cycle, close to Chinese city-bus test cycles.
BEIJING_TARGETS: dict[str, tuple[float, float]] = {
    "duration_s": (1235.0, 1365.0), "mean_speed_kmh": (14.0, 18.0), "max_speed_kmh": (55.0, 62.0),
    "idle_fraction": (0.25, 0.30), "max_abs_accel_mps2": (0.0, 1.1),
}

_KMH = 1.0 / 3.6
_SPEED_DECIMALS = 6
_MAX_APPROACH_STEPS = 10_000


def _step_accel(v_mps: float, a_mps2: float, target_mps: float, accel_limit_mps2: float, decel_limit_mps2: float,
                jerk_mps3: float) -> float:
    """Acceleration over the next 1-s step towards ``target_mps``.

    The desired acceleration follows ``sqrt(2 j dv)`` (the fastest profile from which the
    acceleration can still be ramped to zero at jerk ``j`` on reaching the target), capped by
    the acceleration or deceleration limit, then rate-limited by the jerk and finally clipped
    so that the step never overshoots the target.
    """
    dv = target_mps - v_mps
    # 0.8: margin so the discrete ramp-down keeps within the jerk limit.
    ramp = math.sqrt(2.0 * 0.8 * jerk_mps3 * abs(dv))
    if dv >= 0.0:
        a_des = min(accel_limit_mps2, ramp)
    else:
        a_des = -min(decel_limit_mps2, ramp)
    a_new = min(max(a_des, a_mps2 - jerk_mps3), a_mps2 + jerk_mps3)
    # Never cross the target in one step (this may exceed the jerk limit on the last step).
    if dv >= 0.0:
        a_new = min(a_new, dv)
    else:
        a_new = max(a_new, dv)
    # Physical limits hold even when the jerk limit would ask for more.
    return min(max(a_new, -decel_limit_mps2), accel_limit_mps2)


def _accel_limit_mps2(v_mps: float, *, scale: float, max_accel_mps2: float, power_w_per_kg: float) -> float:
    """Traction acceleration limit: constant at low speed, power-limited above."""
    return scale * min(max_accel_mps2, power_w_per_kg / max(v_mps, 1e-6))


def _build_trip(segments: list[tuple[float, int]], noise: np.ndarray, accel_limit: Callable[[float], float],
                decel_mps2: float, jerk_mps3: float, max_speed_mps: float, noise_std_mps: float,
                noise_corr: float) -> list[float]:
    """Speeds after each 1-s step of one micro-trip from standstill back to standstill.

    ``segments`` is a list of ``(cruise_speed_mps, cruise_s)``; ``noise`` holds standard
    normal draws for the cruise fluctuations (at least the total cruise time).
    """
    v, a = 0.0, 0.0
    out: list[float] = []
    k_noise = 0
    e = 0.0

    def step(target: float) -> None:
        nonlocal v, a
        a = _step_accel(v, a, target, accel_limit(v), decel_mps2, jerk_mps3)
        v = min(max(v + a, 0.0), max_speed_mps)
        out.append(v)

    for cruise_mps, cruise_s in segments:
        for _ in range(_MAX_APPROACH_STEPS):
            if abs(cruise_mps - v) <= 1e-9:
                break
            step(cruise_mps)
        v = cruise_mps
        for _ in range(cruise_s):
            e = noise_corr * e + noise_std_mps * math.sqrt(1.0 - noise_corr**2) * noise[k_noise]
            k_noise += 1
            ref = min(max(cruise_mps + e, 0.5 * cruise_mps), max_speed_mps)
            step(ref)
    for _ in range(_MAX_APPROACH_STEPS):
        if v <= 0.0:
            break
        step(0.0)
    out[-1] = 0.0
    return out


def bus_cycle_params(**kwargs: Any) -> dict[str, Any]:
    """Every parameter of :func:`generate_bus_cycle` with its value: the keyword arguments given (as they would be
    passed to it, without ``seed``, ``name`` and ``description``) and the defaults of the others."""
    sig = inspect.signature(generate_bus_cycle)
    params = {k: p.default for k, p in sig.parameters.items() if k not in ("seed", "name", "description")}
    unknown = set(kwargs) - set(params)
    if unknown:
        raise ValueError(f"unknown generate_bus_cycle parameters: {sorted(unknown)}")
    params.update(kwargs)
    return {k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}


def check_range(name: str, rng_: tuple[float, float], lo: float = 0.0) -> tuple[float, float]:
    a, b = (float(x) for x in rng_)
    if not (math.isfinite(a) and math.isfinite(b)) or a < lo or b < a:
        raise ValueError(f"{name} must be a finite (low, high) pair with {lo} <= low <= high")
    return a, b


def generate_bus_cycle(
    seed: int,
    duration_s: float = 1300.0,
    *,
    max_speed_kmh: float = 60.0,
    cruise_speed_kmh_range: tuple[float, float] = (8.0, 60.0),
    cruise_speed_mode_kmh: float = 10.0,
    cruise_s_range: tuple[float, float] = (0.0, 45.0),
    speed_change_prob: float = 0.25,
    speed_noise_kmh: float = 1.0,
    dwell_s_range: tuple[float, float] = (5.0, 27.0),
    max_accel_mps2: float = 1.0,
    accel_power_w_per_kg: float = 7.0,
    accel_scale_range: tuple[float, float] = (0.8, 1.0),
    decel_mps2_range: tuple[float, float] = (0.7, 1.0),
    max_jerk_mps3: float = 0.5,
    name: str | None = None,
    description: str | None = None,
) -> Cycle:
    """Generate a synthetic stop-to-stop city-bus cycle (the micro-trip model of the module docstring).

    The same seed and arguments always give the same cycle (``numpy.random.default_rng(seed)``).

    * ``seed``: seed of ``numpy.random.default_rng`` (an integer, else ``TypeError``).
    * ``duration_s``: cycle duration [s], rounded to whole seconds (at least 60).
    * ``max_speed_kmh``: hard speed ceiling [km/h], including fluctuations.
    * ``cruise_speed_kmh_range``, ``cruise_speed_mode_kmh``: range and mode [km/h] of the triangular
      distribution of cruise speeds; ``cruise_s_range``: of the uniform cruise durations [s].
    * ``speed_change_prob``: probability of a second cruise speed before a stop; ``speed_noise_kmh``:
      standard deviation of the cruising fluctuation [km/h].
    * ``dwell_s_range``: range of the uniform dwell times at stops [s], also the initial dwell.
    * ``max_accel_mps2`` [m/s²] and ``accel_power_w_per_kg`` [W/kg]: the acceleration limit, constant
      at low speed and ``accel_power_w_per_kg / v`` above; with the defaults the 1-s acceleration and
      deceleration never exceed 1.1 m/s² in magnitude. ``accel_scale_range``: the per-trip driver
      factor on it; ``decel_mps2_range``: the per-trip braking deceleration [m/s²].
    * ``max_jerk_mps3``: limit on the change of acceleration per second [m/s³].
    * ``name``: default ``"bus_seed<seed>"``; ``description``: default a text stating that the cycle
      is synthetic.

    Returns a :class:`Cycle` with ``synthetic=True``, a flat road, speed 0 at the first and last
    sample, and ``metadata`` holding ``synthetic``, ``generator``, ``seed`` and all parameters.
    Raises ``ValueError`` if a parameter is out of range.

    >>> cyc = generate_bus_cycle(seed=3)
    >>> cyc.duration_s, cyc.synthetic, float(cyc.speed_mps[-1])
    (1300.0, True, 0.0)
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    if not (math.isfinite(duration_s) and duration_s >= 60.0):
        raise ValueError(f"duration_s must be at least 60 s, got {duration_s!r}")
    if not (math.isfinite(max_speed_kmh) and max_speed_kmh > 0.0):
        raise ValueError(f"max_speed_kmh must be positive, got {max_speed_kmh!r}")
    cruise_lo, cruise_hi = check_range("cruise_speed_kmh_range", cruise_speed_kmh_range)
    if cruise_lo <= 0.0 or cruise_hi > max_speed_kmh:
        raise ValueError("cruise_speed_kmh_range must lie in (0, max_speed_kmh]")
    cruise_mode = float(cruise_speed_mode_kmh)
    if not (cruise_lo <= cruise_mode <= cruise_hi):
        raise ValueError("cruise_speed_mode_kmh must lie within cruise_speed_kmh_range")
    cruise_s_lo, cruise_s_hi = check_range("cruise_s_range", cruise_s_range)
    dwell_lo, dwell_hi = check_range("dwell_s_range", dwell_s_range)
    scale_lo, scale_hi = check_range("accel_scale_range", accel_scale_range)
    decel_lo, decel_hi = check_range("decel_mps2_range", decel_mps2_range)
    if scale_lo <= 0.0 or decel_lo <= 0.0:
        raise ValueError("accel_scale_range and decel_mps2_range must be positive")
    for label, value in (("max_accel_mps2", max_accel_mps2), ("accel_power_w_per_kg", accel_power_w_per_kg),
                         ("max_jerk_mps3", max_jerk_mps3)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{label} must be positive, got {value!r}")
    if not (0.0 <= speed_change_prob <= 1.0):
        raise ValueError(f"speed_change_prob must be in [0, 1], got {speed_change_prob!r}")
    if not (math.isfinite(speed_noise_kmh) and speed_noise_kmh >= 0.0):
        raise ValueError(f"speed_noise_kmh must be >= 0, got {speed_noise_kmh!r}")

    params: dict[str, Any] = {
        "duration_s": float(duration_s), "max_speed_kmh": float(max_speed_kmh),
        "cruise_speed_kmh_range": [cruise_lo, cruise_hi], "cruise_speed_mode_kmh": cruise_mode,
        "cruise_s_range": [cruise_s_lo, cruise_s_hi], "speed_change_prob": float(speed_change_prob),
        "speed_noise_kmh": float(speed_noise_kmh), "dwell_s_range": [dwell_lo, dwell_hi],
        "max_accel_mps2": float(max_accel_mps2), "accel_power_w_per_kg": float(accel_power_w_per_kg),
        "accel_scale_range": [scale_lo, scale_hi], "decel_mps2_range": [decel_lo, decel_hi],
        "max_jerk_mps3": float(max_jerk_mps3),
    }

    rng = np.random.default_rng(int(seed))
    n_total = int(round(duration_s))
    max_speed_mps = max_speed_kmh * _KMH
    noise_std_mps = speed_noise_kmh * _KMH
    noise_corr = 0.9
    min_trip_speed_mps = min(10.0 * _KMH, cruise_lo * _KMH)

    def draw_dwell() -> int:
        return int(round(rng.uniform(dwell_lo, dwell_hi)))

    def draw_cruise() -> tuple[float, int]:
        speed_kmh = rng.triangular(cruise_lo, cruise_mode, cruise_hi) if cruise_hi > cruise_lo else cruise_lo
        return speed_kmh * _KMH, int(round(rng.uniform(cruise_s_lo, cruise_s_hi)))

    speeds: list[float] = [0.0] * (1 + min(draw_dwell(), n_total))
    n_trips = 0
    while len(speeds) - 1 < n_total:
        remaining = n_total - (len(speeds) - 1)
        segments = [draw_cruise()]
        if rng.random() < speed_change_prob:
            segments.append(draw_cruise())
        scale = rng.uniform(scale_lo, scale_hi)
        decel = rng.uniform(decel_lo, decel_hi)
        dwell = draw_dwell()
        noise = rng.standard_normal(sum(s for _, s in segments))

        accel_limit = functools.partial(_accel_limit_mps2, scale=scale, max_accel_mps2=max_accel_mps2,
                                        power_w_per_kg=accel_power_w_per_kg)
        build = functools.partial(_build_trip, noise=noise, accel_limit=accel_limit, decel_mps2=decel,
                                  jerk_mps3=max_jerk_mps3, max_speed_mps=max_speed_mps, noise_std_mps=noise_std_mps,
                                  noise_corr=noise_corr)

        # Shorten a trip that does not fit, keeping at least one second of final dwell:
        # first drop the second segment and cruise time, then lower the speed.
        trip = build(segments)
        if len(trip) + 1 > remaining:
            seg = [(segments[0][0], 0)]
            trip = build(seg)
            while len(trip) + 1 > remaining and seg[0][0] * 0.9 >= min_trip_speed_mps:
                seg = [(seg[0][0] * 0.9, 0)]
                trip = build(seg)
            if len(trip) + 1 > remaining:
                speeds.extend([0.0] * remaining)
                break
        speeds.extend(trip)
        n_trips += 1
        remaining = n_total - (len(speeds) - 1)
        speeds.extend([0.0] * min(max(dwell, 1), remaining))

    speed_mps = np.round(np.asarray(speeds, dtype=np.float64), _SPEED_DECIMALS)
    speed_mps = np.maximum(speed_mps, 0.0) + 0.0  # no negative zeros
    metadata = {"synthetic": True, "generator": "hev_thermal_env.cycles.generate_bus_cycle", "seed": int(seed),
                "params": params, "n_trips": n_trips}
    if description is None:
        description = f"Synthetic city-bus cycle (generated, not measured), seed {int(seed)}"
    return Cycle(name=name if name is not None else f"bus_seed{int(seed)}",
                 time_s=np.arange(n_total + 1, dtype=np.float64), speed_mps=speed_mps, grade=np.zeros(n_total + 1),
                 synthetic=True, description=description, source="hev_thermal_env.cycles.generator.generate_bus_cycle",
                 metadata=metadata)
