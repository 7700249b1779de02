"""Seeded road grade profiles under any cycle: hilly routes for the heat scenarios.

:func:`generate_grade_profile` draws a road along the distance from its own seed (so no flat cycle changes):
normal grades clipped to ``±max_grade`` on segments, joined by vertical curves, and (``closed``) ending at the
height it started (a bus line loops back: no net climb to bias the fuel). :func:`with_grade_profile` lays it
under any cycle; the ``hilly`` scenario lays the road of :data:`HILLY_SEED` under its cycles.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .cycle import Cycle
from .generator import check_range

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
    if closed:
        for _ in range(50):  # remove the net climb, re-clipping; converges in a few rounds
            grades = np.clip(grades - np.sum(grades * seg) / np.sum(seg), -max_grade, max_grade)
    ends = np.cumsum(seg)
    starts = ends - seg
    half = 0.5 * transition_m
    pos = [0.0]
    val = [float(grades[0])]
    for i in range(1, len(seg)):  # vertical curve around the boundary at starts[i]
        pos += [starts[i] - half, starts[i] + half]
        val += [float(grades[i - 1]), float(grades[i])]
    pos.append(float(ends[-1]))
    val.append(float(grades[-1]))
    return np.asarray(pos), np.asarray(val)


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
    params = {k: list(x) if isinstance(x, tuple) else x for k, x in kwargs.items()}
    metadata = {**cycle.metadata, "grade_profile": {"seed": int(seed), "params": params,
                                                    "generator": "hev_thermal_env.cycles.generate_grade_profile"}}
    return Cycle(name=name if name is not None else f"{cycle.name}_hilly{int(seed)}",
                 time_s=np.asarray(cycle.time_s, dtype=np.float64), speed_mps=v, grade=grade, synthetic=True,
                 description=f"{cycle.description or cycle.name} over a generated hilly road (seed {int(seed)}, "
                             "synthetic)",
                 source=f"{cycle.source}; grade from hev_thermal_env.cycles.generate_grade_profile(seed={int(seed)})",
                 metadata=metadata)

