"""Seeded synthetic city-bus cycles (stop-to-stop micro-trips) and hilly roads under any cycle.

A bus cycle is a chain of micro-trips, each from standstill to standstill: dwell, accelerate, cruise (possibly
change speed, traffic), brake to a stop. Dwells, cruise durations, per-trip driver factors on the traction curve
and braking decelerations are uniform draws; cruise targets triangular (most trips slow, a few fast). Acceleration
follows a bus traction curve, constant at low speed and power-limited (∝ 1/v) above; a cruise follows its target
plus a first-order autoregressive fluctuation. Every change of acceleration is limited by the jerk and targets are
approached along a jerk-limited profile that lands on them exactly (only that last step may exceed the jerk limit
slightly). The cycle lasts exactly ``round(duration_s)`` seconds and ends at standstill: a trip that would
overrun is shortened (shorter cruise, then lower speed) and the remainder becomes the final dwell. Speeds are
rounded to 1e-6 m/s so that a generated cycle written to CSV reads back identically; the road is flat. The
built-in ``beijing`` cycle is this generator with :data:`BEIJING_SEED` and :data:`BEIJING_KWARGS` (synthetic, not a
measured Beijing bus cycle).

:func:`generate_grade_profile` draws a road along the distance from its own seed (so no flat cycle changes);
:func:`with_grade_profile` lays it under any cycle, the ``hilly`` scenario the road of :data:`HILLY_SEED`.
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
    """Acceleration over the next 1-s step towards ``target_mps``: ``sqrt(2 j dv)`` (the fastest profile from which
    the acceleration can still be ramped to zero at jerk ``j`` on reaching the target), capped by the acceleration
    or deceleration limit, rate-limited by the jerk and clipped so that the step never overshoots the target."""
    dv = target_mps - v_mps
    # 0.8: margin so the discrete ramp-down keeps within the jerk limit.
    ramp = math.sqrt(2.0 * 0.8 * jerk_mps3 * abs(dv))
    a_des = min(accel_limit_mps2, ramp) if dv >= 0.0 else -min(decel_limit_mps2, ramp)
    a_new = min(max(a_des, a_mps2 - jerk_mps3), a_mps2 + jerk_mps3)
    # Never cross the target in one step (this may exceed the jerk limit on the last step).
    a_new = min(a_new, dv) if dv >= 0.0 else max(a_new, dv)
    # Physical limits hold even when the jerk limit would ask for more.
    return min(max(a_new, -decel_limit_mps2), accel_limit_mps2)


def _accel_limit_mps2(v_mps: float, *, scale: float, max_accel_mps2: float, power_w_per_kg: float) -> float:
    """Traction acceleration limit: constant at low speed, power-limited above."""
    return scale * min(max_accel_mps2, power_w_per_kg / max(v_mps, 1e-6))


def _build_trip(segments: list[tuple[float, int]], noise: np.ndarray, accel_limit: Callable[[float], float],
                decel_mps2: float, jerk_mps3: float, max_speed_mps: float, noise_std_mps: float,
                noise_corr: float) -> list[float]:
    """Speeds after each 1-s step of one micro-trip from standstill back to standstill over ``segments``
    ``(cruise_speed_mps, cruise_s)``; ``noise``: standard normal draws, one per second of cruise."""
    v = a = e = 0.0
    out: list[float] = []
    k_noise = 0

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
            step(min(max(cruise_mps + e, 0.5 * cruise_mps), max_speed_mps))
    for _ in range(_MAX_APPROACH_STEPS):
        if v <= 0.0:
            break
        step(0.0)
    out[-1] = 0.0
    return out


def as_lists(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with tuples as lists (a cycle's metadata, JSON-like)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in kwargs.items()}


def check_range(name: str, rng_: tuple[float, float]) -> tuple[float, float]:
    a, b = (float(x) for x in rng_)
    if not (math.isfinite(a) and math.isfinite(b)) or a < 0.0 or b < a:
        raise ValueError(f"{name} must be a finite (low, high) pair with 0.0 <= low <= high")
    return a, b


def bus_cycle_params(**kwargs: Any) -> dict[str, Any]:
    """Every parameter of :func:`generate_bus_cycle` but ``seed``, ``name`` and ``description``, as its cycles'
    metadata holds them: the keyword arguments given and the defaults of the others, as floats and ``[low, high]``
    lists; ``ValueError`` naming an unknown parameter or a value out of range."""
    sig = inspect.signature(generate_bus_cycle)
    p = {k: prm.default for k, prm in sig.parameters.items() if k not in ("seed", "name", "description")}
    unknown = set(kwargs) - set(p)
    if unknown:
        raise ValueError(f"unknown generate_bus_cycle parameters: {sorted(unknown)}")
    p.update(kwargs)
    if not (math.isfinite(p["duration_s"]) and p["duration_s"] >= 60.0):
        raise ValueError(f"duration_s must be at least 60 s, got {p['duration_s']!r}")
    for label in ("max_speed_kmh", "max_accel_mps2", "accel_power_w_per_kg", "max_jerk_mps3"):
        if not (math.isfinite(p[label]) and p[label] > 0.0):
            raise ValueError(f"{label} must be positive, got {p[label]!r}")
    for label in ("cruise_speed_kmh_range", "cruise_s_range", "dwell_s_range", "accel_scale_range", "decel_mps2_range"):
        p[label] = list(check_range(label, p[label]))
    cruise_lo, cruise_hi = p["cruise_speed_kmh_range"]
    if cruise_lo <= 0.0 or cruise_hi > p["max_speed_kmh"]:
        raise ValueError("cruise_speed_kmh_range must lie in (0, max_speed_kmh]")
    if not (cruise_lo <= float(p["cruise_speed_mode_kmh"]) <= cruise_hi):
        raise ValueError("cruise_speed_mode_kmh must lie within cruise_speed_kmh_range")
    if p["accel_scale_range"][0] <= 0.0 or p["decel_mps2_range"][0] <= 0.0:
        raise ValueError("accel_scale_range and decel_mps2_range must be positive")
    if not (0.0 <= p["speed_change_prob"] <= 1.0):
        raise ValueError(f"speed_change_prob must be in [0, 1], got {p['speed_change_prob']!r}")
    if not (math.isfinite(p["speed_noise_kmh"]) and p["speed_noise_kmh"] >= 0.0):
        raise ValueError(f"speed_noise_kmh must be >= 0, got {p['speed_noise_kmh']!r}")
    return {k: v if isinstance(v, list) else float(v) for k, v in p.items()}


def _micro_trips(rng: np.random.Generator, n_total: int, p: dict[str, Any]) -> tuple[list[float], int]:
    """The speeds [m/s] of ``n_total`` 1-s steps of dwells and micro-trips from standstill (``p``: the checked
    parameters), and the number of trips. The order of the draws fixes every generated cycle."""
    cruise_lo, cruise_hi = p["cruise_speed_kmh_range"]
    cruise_mode = p["cruise_speed_mode_kmh"]
    min_trip_speed_mps = min(10.0 * _KMH, cruise_lo * _KMH)

    def draw_dwell() -> int:
        return int(round(rng.uniform(*p["dwell_s_range"])))

    def draw_cruise() -> tuple[float, int]:
        speed_kmh = rng.triangular(cruise_lo, cruise_mode, cruise_hi) if cruise_hi > cruise_lo else cruise_lo
        return speed_kmh * _KMH, int(round(rng.uniform(*p["cruise_s_range"])))

    speeds: list[float] = [0.0] * (1 + min(draw_dwell(), n_total))
    n_trips = 0
    while len(speeds) - 1 < n_total:
        remaining = n_total - (len(speeds) - 1)
        segments = [draw_cruise()]
        if rng.random() < p["speed_change_prob"]:
            segments.append(draw_cruise())
        scale = rng.uniform(*p["accel_scale_range"])
        decel = rng.uniform(*p["decel_mps2_range"])
        dwell = draw_dwell()
        noise = rng.standard_normal(sum(s for _, s in segments))
        accel_limit = functools.partial(_accel_limit_mps2, scale=scale, max_accel_mps2=p["max_accel_mps2"],
                                        power_w_per_kg=p["accel_power_w_per_kg"])
        build = functools.partial(_build_trip, noise=noise, accel_limit=accel_limit, decel_mps2=decel,
                                  jerk_mps3=p["max_jerk_mps3"], max_speed_mps=p["max_speed_kmh"] * _KMH,
                                  noise_std_mps=p["speed_noise_kmh"] * _KMH, noise_corr=0.9)
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
    return speeds, n_trips


def generate_bus_cycle(seed: int, duration_s: float = 1300.0, *, max_speed_kmh: float = 60.0,
                       cruise_speed_kmh_range: tuple[float, float] = (8.0, 60.0), cruise_speed_mode_kmh: float = 10.0,
                       cruise_s_range: tuple[float, float] = (0.0, 45.0), speed_change_prob: float = 0.25,
                       speed_noise_kmh: float = 1.0, dwell_s_range: tuple[float, float] = (5.0, 27.0),
                       max_accel_mps2: float = 1.0, accel_power_w_per_kg: float = 7.0,
                       accel_scale_range: tuple[float, float] = (0.8, 1.0),
                       decel_mps2_range: tuple[float, float] = (0.7, 1.0), max_jerk_mps3: float = 0.5,
                       name: str | None = None, description: str | None = None) -> Cycle:
    """A synthetic stop-to-stop city-bus cycle (the micro-trip model of the module docstring); the same seed
    (``numpy.random.default_rng(seed)``, an integer) and arguments always give the same cycle.

    ``duration_s`` is rounded to whole seconds (at least 60); ``max_speed_kmh`` is a hard ceiling. Cruise speeds
    are triangular over ``cruise_speed_kmh_range`` with mode ``cruise_speed_mode_kmh``; cruise durations
    (``cruise_s_range``) and dwells (``dwell_s_range``, also the initial dwell) uniform [s].
    ``speed_change_prob``: chance of a second cruise speed before a stop; ``speed_noise_kmh``: standard deviation
    of the cruising fluctuation. The acceleration limit is ``max_accel_mps2``, ``accel_power_w_per_kg / v``
    above (with the defaults |a| never exceeds 1.1 m/s²), times a per-trip driver factor from
    ``accel_scale_range``; braking at a per-trip deceleration from ``decel_mps2_range`` [m/s²]; ``max_jerk_mps3``
    limits the change of acceleration per second. ``name`` defaults to ``"bus_seed<seed>"``.

    Returns a :class:`Cycle` with ``synthetic=True``, a flat road, speed 0 at the first and last sample, and
    ``metadata`` holding ``synthetic``, ``generator``, ``seed``, all parameters and ``n_trips``. Raises
    ``TypeError`` for a seed that is not an integer, ``ValueError`` if a parameter is out of range.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    params = bus_cycle_params(
        duration_s=duration_s, max_speed_kmh=max_speed_kmh, cruise_speed_kmh_range=cruise_speed_kmh_range,
        cruise_speed_mode_kmh=cruise_speed_mode_kmh, cruise_s_range=cruise_s_range,
        speed_change_prob=speed_change_prob, speed_noise_kmh=speed_noise_kmh, dwell_s_range=dwell_s_range,
        max_accel_mps2=max_accel_mps2, accel_power_w_per_kg=accel_power_w_per_kg,
        accel_scale_range=accel_scale_range, decel_mps2_range=decel_mps2_range, max_jerk_mps3=max_jerk_mps3)
    n_total = int(round(duration_s))
    speeds, n_trips = _micro_trips(np.random.default_rng(int(seed)), n_total, params)
    speed_mps = np.round(np.asarray(speeds, dtype=np.float64), _SPEED_DECIMALS)
    speed_mps = np.maximum(speed_mps, 0.0) + 0.0  # no negative zeros
    metadata = {"synthetic": True, "generator": "hev_thermal_env.cycles.generate_bus_cycle", "seed": int(seed),
                "params": params, "n_trips": n_trips}
    return Cycle(name=name if name is not None else f"bus_seed{int(seed)}",
                 time_s=np.arange(n_total + 1, dtype=np.float64), speed_mps=speed_mps, grade=np.zeros(n_total + 1),
                 synthetic=True, metadata=metadata, source="hev_thermal_env.cycles.generator.generate_bus_cycle",
                 description=f"Synthetic city-bus cycle (generated, not measured), seed {int(seed)}"
                 if description is None else description)


#: Seed of the road profile of the ``hilly`` scenario.
HILLY_SEED = 2024


def hill_kwargs(max_grade: float) -> dict[str, Any]:
    """:func:`generate_grade_profile` arguments of rolling hills with grades up to ``±max_grade``."""
    return {"max_grade": float(max_grade), "grade_std": 0.5 * float(max_grade), "segment_m_range": (150.0, 600.0),
            "transition_m": 40.0, "closed": True}


#: Keyword arguments of :func:`generate_grade_profile` for the ``hilly`` scenario: rolling city hills up to ±7 %.
HILLY_KWARGS: dict[str, Any] = hill_kwargs(0.07)


def generate_grade_profile(seed: int, length_m: float, *, max_grade: float = 0.07, grade_std: float = 0.035,
                           segment_m_range: tuple[float, float] = (150.0, 600.0), transition_m: float = 40.0,
                           closed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A seeded road, piecewise linear in the returned (positions [m], grade there) from 0 to at least ``length_m``.

    Grades (rise/run) are constant on segments of ``segment_m_range`` metres, with linear vertical curves of
    ``transition_m`` between them; with ``closed`` the length-weighted mean grade is removed (no net climb).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be positive, got {length_m!r}")
    if not (0.0 < max_grade <= 0.3) or not (grade_std >= 0.0):
        raise ValueError("max_grade must lie in (0, 0.3] and grade_std be >= 0")
    seg_lo, seg_hi = check_range("segment_m_range", segment_m_range)
    if seg_lo <= 0.0 or not (0.0 <= transition_m < seg_lo):
        raise ValueError("segment_m_range must be positive and transition_m in [0, its low end)")
    rng = np.random.default_rng(int(seed))
    lengths: list[float] = []
    while sum(lengths) < length_m:
        lengths.append(float(rng.uniform(seg_lo, seg_hi)))
    seg = np.asarray(lengths)
    grades = np.clip(rng.normal(0.0, grade_std, len(seg)), -max_grade, max_grade)
    for _ in range(50 if closed else 0):  # remove the net climb, re-clipping; converges in a few rounds
        grades = np.clip(grades - np.sum(grades * seg) / np.sum(seg), -max_grade, max_grade)
    ends = np.cumsum(seg)
    starts = ends - seg
    pos, val = [0.0], [float(grades[0])]
    for i in range(1, len(seg)):  # vertical curve around the boundary at starts[i]
        pos += [starts[i] - 0.5 * transition_m, starts[i] + 0.5 * transition_m]
        val += [float(grades[i - 1]), float(grades[i])]
    return np.asarray(pos + [float(ends[-1])]), np.asarray(val + [float(grades[-1])])


def grade_along(speed_mps: np.ndarray, seed: int, **kwargs: Any) -> np.ndarray:
    """The grade under each sample of a 1-s speed trace driven over the road of :func:`generate_grade_profile`:
    step k climbs the grade at the middle of the distance it covers, the last sample repeats the last step's grade;
    rounded to 1e-9 (a CSV round trip keeps it)."""
    v = np.asarray(speed_mps, dtype=np.float64)
    step_m = 0.5 * (v[1:] + v[:-1])
    start_m = np.concatenate([[0.0], np.cumsum(step_m)[:-1]])
    mid_m = start_m + 0.5 * step_m
    pos, val = generate_grade_profile(seed, max(float(np.sum(step_m)), 1.0), **kwargs)
    g = np.interp(mid_m, pos, val)
    return np.round(np.concatenate([g, g[-1:]]), 9) + 0.0


def with_grade_profile(cycle: Cycle, seed: int, *, name: str | None = None, **kwargs: Any) -> Cycle:
    """``cycle``'s speeds over the road of :func:`generate_grade_profile` (``seed``, ``kwargs``), sampled by
    :func:`grade_along`; the cycle's own grade is replaced."""
    v = np.asarray(cycle.speed_mps, dtype=np.float64)
    grade = grade_along(v, seed, **kwargs)
    metadata = {**cycle.metadata, "grade_profile": {"seed": int(seed), "params": as_lists(kwargs),
                                                    "generator": "hev_thermal_env.cycles.generate_grade_profile"}}
    return Cycle(name=name if name is not None else f"{cycle.name}_hilly{int(seed)}",
                 time_s=np.asarray(cycle.time_s, dtype=np.float64), speed_mps=v, grade=grade, synthetic=True,
                 description=f"{cycle.description or cycle.name} over a generated hilly road (seed {int(seed)}, "
                             "synthetic)",
                 source=f"{cycle.source}; grade from hev_thermal_env.cycles.generate_grade_profile(seed={int(seed)})",
                 metadata=metadata)

