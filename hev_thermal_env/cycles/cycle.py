"""The :class:`Cycle` container (read-only arrays, shared between environments without copies) and the sample checks
shared by every cycle source."""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: Speed below which a 1-s sample counts as standing still [m/s].
IDLE_SPEED_MPS = 0.1
#: Largest accepted ``|grade|`` (rise/run). Steeper values are almost surely percent or degrees.
MAX_ABS_GRADE = 0.5
#: Tolerance on the time grid [s] (time stamps written with a few decimals still pass).
TIME_TOL_S = 1e-6
#: Speed above which a user cycle sample is implausible for a city bus [m/s] (126 km/h; the paper's bus
#: tops out at 89 km/h). A cycle in km/h under a ``speed_mps`` header exceeds it at any highway speed.
PLAUSIBLE_SPEED_MAX_MPS = 35.0
#: Largest plausible |acceleration| of a bus over one step of a user cycle [m/s²] (hard braking is about
#: 3 m/s², a city bus accelerates at 1-1.5 m/s²). Speeds in km/h read as m/s multiply it by 3.6.
PLAUSIBLE_ACCEL_MAX_MPS2 = 3.5


class ImplausibleCycleWarning(UserWarning):
    """User cycle data beyond a bus's range (speed or acceleration): used as given, but most likely a unit
    mistake (km/h under a ``speed_mps`` header) or a glitch in the recording."""

Locate = Callable[[int], str]
_index_locator: Locate = "index {}".format


def _first(mask: np.ndarray) -> int | None:
    """The index of the first True in ``mask``, or None."""
    hits = np.flatnonzero(mask)
    return int(hits[0]) if hits.size else None


def check_samples(time_s: np.ndarray, speed_mps: np.ndarray, grade: np.ndarray, *, origin: str,
                  locate: Locate = _index_locator) -> float:
    """The uniform time step [s] of raw cycle samples (1-D float arrays of equal length); a ``ValueError`` starting
    with ``origin`` and the position (``locate`` of the 0-based sample index) for fewer than two samples, NaN/inf, a
    negative speed, ``|grade|`` above :data:`MAX_ABS_GRADE`, or a time that does not increase by a uniform step."""

    def fail(i: int, problem: str) -> ValueError:
        return ValueError(f"{origin}: {locate(i)}: {problem}")

    n = len(speed_mps)
    if not (len(time_s) == n == len(grade)):
        raise ValueError(f"{origin}: length mismatch: time_s has {len(time_s)} samples, speed_mps {n}, "
                         f"grade {len(grade)}")
    if n < 2:
        raise ValueError(f"{origin}: need at least 2 samples to define a time step, found {n}")
    for label, arr in (("time_s", time_s), ("speed_mps", speed_mps), ("grade", grade)):
        if (i := _first(~np.isfinite(arr))) is not None:
            raise fail(i, f"{label} value {float(arr[i])} is not finite (NaN or inf)")
    if (i := _first(speed_mps < 0.0)) is not None:
        raise fail(i, f"negative speed: speed_mps = {float(speed_mps[i])!r} (must be >= 0)")
    if (i := _first(np.abs(grade) > MAX_ABS_GRADE)) is not None:
        raise fail(i, f"grade = {float(grade[i])!r} is not a plausible rise/run fraction "
                      f"(|grade| <= {MAX_ABS_GRADE}; 0.04 means 4 %, not 4)")
    dt = np.diff(time_s)
    if (i := _first(dt <= 0.0)) is not None:
        raise fail(i + 1, f"time not increasing: time_s = {float(time_s[i + 1])!r} follows {float(time_s[i])!r}")
    dt0 = float(dt[0])
    if (i := _first(np.abs(dt - dt0) > TIME_TOL_S * max(1.0, dt0))) is not None:
        raise fail(i + 1, f"non-uniform time step: {float(dt[i])!r} s from time_s = {float(time_s[i])!r} to "
                          f"{float(time_s[i + 1])!r}, but the first step is {dt0!r} s "
                          "(only uniformly sampled cycles are supported)")
    return dt0


def warn_implausible(time_s: np.ndarray, speed_mps: np.ndarray, *, origin: str,
                     locate: Locate = _index_locator) -> None:
    """Warn (:class:`ImplausibleCycleWarning`) about speeds above :data:`PLAUSIBLE_SPEED_MAX_MPS` and accelerations
    beyond ±:data:`PLAUSIBLE_ACCEL_MAX_MPS2`, naming the first such sample, its value and how many there are."""
    accel = np.diff(speed_mps) / np.diff(time_s)
    findings = []
    fast = np.flatnonzero(speed_mps > PLAUSIBLE_SPEED_MAX_MPS)
    if fast.size:
        i = int(fast[0])
        findings.append((i, f"speed_mps = {float(speed_mps[i]):g} is beyond a bus's range (above "
                            f"{PLAUSIBLE_SPEED_MAX_MPS:g} m/s = {3.6 * PLAUSIBLE_SPEED_MAX_MPS:g} km/h; {fast.size} "
                            f"sample(s), up to {float(speed_mps.max()):g}); km/h values under a speed_mps header?"))
    hard = np.flatnonzero(np.abs(accel) > PLAUSIBLE_ACCEL_MAX_MPS2)
    if hard.size:
        i = int(hard[0])
        findings.append((i + 1, f"acceleration {float(accel[i]):+g} m/s² (speed_mps {float(speed_mps[i]):g} -> "
                                f"{float(speed_mps[i + 1]):g}) is beyond a bus's range (|a| above "
                                f"{PLAUSIBLE_ACCEL_MAX_MPS2:g} m/s²; {hard.size} step(s), up to "
                                f"{float(np.abs(accel).max()):g})."))
    for row, finding in findings:
        warnings.warn(f"{origin}: {locate(row)}: {finding} The cycle is used as given.", ImplausibleCycleWarning,
                      stacklevel=4)


def to_1s_grid(time_s: np.ndarray, speed_mps: np.ndarray, grade: np.ndarray, *, origin: str,
               locate: Locate = _index_locator,
               plausibility: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Samples checked (:func:`check_samples`; with ``plausibility`` also :func:`warn_implausible`) and shifted to
    0 s on a 1-s grid, with ``original_time_step_s``, ``time_offset_s`` and ``resampled``.

    A 1-s step only snaps the time stamps to ``0, 1, 2, ...``; any other step is interpolated linearly onto the
    whole seconds covered (``resampled``; a trailing fraction of a second is dropped, a step below 1 s picks
    interpolated points and does not average).
    """
    dt_s = check_samples(time_s, speed_mps, grade, origin=origin, locate=locate)
    if plausibility:
        warn_implausible(time_s, speed_mps, origin=origin, locate=locate)
    info: dict[str, Any] = {"original_time_step_s": dt_s, "time_offset_s": float(time_s[0]),
                            "resampled": abs(dt_s - 1.0) > TIME_TOL_S}
    t_rel = time_s - time_s[0]
    time_s = np.arange(int(math.floor(t_rel[-1] + TIME_TOL_S)) + 1 if info["resampled"] else len(t_rel),
                       dtype=np.float64)
    if info["resampled"]:
        speed_mps = np.maximum(np.interp(time_s, t_rel, speed_mps), 0.0)
        grade = np.interp(time_s, t_rel, grade)
    if len(time_s) < 2:
        raise ValueError(f"{origin}: cycle is shorter than 1 s, nothing left on a 1-s grid")
    return time_s, speed_mps, grade, info


def float_vector(label: str, values: Any, origin: str) -> np.ndarray:
    """``values`` as a 1-D float64 array; else a ``ValueError`` naming ``origin``, ``label`` and the index of the
    first non-numeric value."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        for i, x in enumerate(np.asarray(values, dtype=object).ravel()):
            try:
                float(x)
            except (TypeError, ValueError):
                raise ValueError(f"{origin}: index {i}: non-numeric value {x!r} in {label}") from None
        raise ValueError(f"{origin}: {label} is not numeric") from None
    if arr.ndim != 1:
        raise ValueError(f"{origin}: {label} must be 1-D, got shape {arr.shape}")
    return arr


@dataclasses.dataclass(frozen=True, eq=False)
class Cycle:
    """A drive cycle sampled at 1 s: ``time_s`` ``0, 1, 2, ...`` [s], ``speed_mps`` ``>= 0`` and ``grade`` (rise/run:
    0.04 is a 4 % climb), stored as read-only float64 copies; instances compare by identity.

    Build cycles with :func:`~hev_thermal_env.cycles.load_cycle`, :func:`~hev_thermal_env.cycles.cycle_from_arrays`
    or :func:`~hev_thermal_env.cycles.generate_bus_cycle`; the constructor accepts only data already on the 1-s
    grid. ``synthetic``: generated rather than measured; ``metadata``: free-form (a generated cycle's seed and
    parameters, a resampled file's original time step).
    """

    name: str
    time_s: np.ndarray
    speed_mps: np.ndarray
    grade: np.ndarray
    synthetic: bool = False
    description: str = ""
    source: str = ""
    metadata: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        origin = f"Cycle {self.name!r}"
        for label in ("time_s", "speed_mps", "grade"):
            arr = np.array(float_vector(label, getattr(self, label), origin))  # a copy, read-only
            arr.flags.writeable = False
            object.__setattr__(self, label, arr)
        check_samples(self.time_s, self.speed_mps, self.grade, origin=origin)
        if np.any(np.abs(self.time_s - np.arange(len(self.time_s))) > TIME_TOL_S):
            raise ValueError(f"{origin}: time_s must be 0, 1, 2, ... s; use cycle_from_arrays to shift or resample "
                             "other time grids")
        object.__setattr__(self, "synthetic", bool(self.synthetic))
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def duration_s(self) -> float:
        """Duration [s]: the last time stamp."""
        return float(self.time_s[-1])

    @property
    def n_steps(self) -> int:
        """Number of 1-s steps (samples minus one)."""
        return len(self.time_s) - 1

    @property
    def distance_m(self) -> float:
        """Distance [m]: trapezoidal integral of the speed over time."""
        v = self.speed_mps
        return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(self.time_s)))

    distance_km = property(lambda self: self.distance_m / 1000.0, doc="Distance [km].")
    mean_speed_kmh = property(lambda self: 3.6 * self.distance_m / self.duration_s,
                      doc="Mean speed including stops [km/h]: distance divided by duration.")
    max_speed_kmh = property(lambda self: 3.6 * float(np.max(self.speed_mps)), doc="Maximum speed [km/h].")
    idle_fraction = property(lambda self: float(np.mean(self.speed_mps < IDLE_SPEED_MPS)),
                      doc="Fraction of 1-s samples with speed below 0.1 m/s.")
    accel_mps2 = property(lambda self: np.diff(self.speed_mps) / np.diff(self.time_s),
                      doc="Forward-difference acceleration [m/s^2] over each 1-s step (length ``n_steps``).")
    max_abs_accel_mps2 = property(lambda self: float(np.max(np.abs(self.accel_mps2))),
                      doc="Largest ``|acceleration|`` [m/s^2] from the 1-s forward difference of the speed.")

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write the cycle to ``path`` (overwritten) as CSV ``time_s,speed_mps,grade`` and return the path;
        ``load_cycle(cycle.to_csv(p))`` reproduces the arrays exactly."""
        path = Path(path)
        rows = zip(self.time_s, self.speed_mps, self.grade)  # repr: reads back the same float
        lines = ["time_s,speed_mps,grade"] + [f"{float(t)!r},{float(v)!r},{float(g)!r}" for t, v, g in rows]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path

    def __repr__(self) -> str:
        kind = "synthetic" if self.synthetic else "data"
        return (f"Cycle(name={self.name!r}, {kind}, duration_s={self.duration_s:.0f}, "
                f"distance_km={self.distance_km:.3f}, mean_speed_kmh={self.mean_speed_kmh:.2f})")
