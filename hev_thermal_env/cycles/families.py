"""Named, seeded families of synthetic bus cycles (:data:`FAMILIES`): chains of *segments*, each a
:func:`~hev_thermal_env.cycles.generate_bus_cycle` run of one kind (:data:`SEGMENT_KINDS`), joined at standstill,
optionally over a closed hilly road (:func:`~hev_thermal_env.cycles.generate_grade_profile`, no net climb), within
what the loader accepts without an :class:`~hev_thermal_env.cycles.ImplausibleCycleWarning`. What each family covers,
its statistics and the seeds: docs/cycle-families.md.

Seeds: training draws from ``[0, TRAINING_SEED_LIMIT)`` (:func:`training_seed`), the validation set from
:data:`VALIDATION_SEED_BASE` up; segments, roads and the per-cycle draws take :func:`inner_seed`, injective onto
integers from 2**48 up (no family cycle shares a generator seed with another, a built-in or a ``random_bus`` cycle).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from .cycle import IDLE_SPEED_MPS, Cycle
from .generator import BEIJING_SEED, as_lists, generate_bus_cycle, grade_along, hill_kwargs

#: Training seeds are drawn from ``[0, TRAINING_SEED_LIMIT)``.
TRAINING_SEED_LIMIT = 2**31 - 1
#: Validation cycle ``k`` has seed ``VALIDATION_SEED_BASE + k``: above every training seed.
VALIDATION_SEED_BASE = 2**31
#: Seeds training never draws: ``random_bus`` with seed 171 is the ``beijing`` evaluation cycle.
RESERVED_TRAINING_SEEDS: dict[str, frozenset[int]] = {"random_bus": frozenset({BEIJING_SEED})}
_INNER_BASE = 2**48
_PARTS = 64

#: ``generate_bus_cycle`` arguments of each kind of segment (the draws of :func:`_segment_kwargs` added).
SEGMENT_KINDS: dict[str, dict[str, Any]] = {
    "city": {},
    "congested": {"max_speed_kmh": 35.0, "cruise_speed_kmh_range": (5.0, 30.0), "cruise_speed_mode_kmh": 8.0,
                  "cruise_s_range": (0.0, 12.0), "speed_change_prob": 0.5, "speed_noise_kmh": 0.8,
                  "dwell_s_range": (3.0, 25.0), "max_accel_mps2": 0.8, "decel_mps2_range": (0.6, 0.9)},
    "launch": {"cruise_speed_kmh_range": (10.0, 50.0), "cruise_speed_mode_kmh": 20.0, "cruise_s_range": (0.0, 30.0),
               "accel_scale_range": (0.9, 1.0), "decel_mps2_range": (1.0, 2.0), "max_jerk_mps3": 1.5},
    "suburban": {"max_speed_kmh": 70.0, "cruise_speed_kmh_range": (20.0, 70.0), "cruise_speed_mode_kmh": 40.0,
                 "cruise_s_range": (20.0, 120.0), "speed_change_prob": 0.4, "dwell_s_range": (5.0, 30.0)},
    "motorway": {"max_speed_kmh": 115.0, "cruise_speed_kmh_range": (60.0, 110.0), "cruise_speed_mode_kmh": 90.0,
                 "cruise_s_range": (60.0, 420.0), "speed_change_prob": 0.7, "speed_noise_kmh": 1.5,
                 "dwell_s_range": (5.0, 40.0), "max_accel_mps2": 1.5, "accel_scale_range": (0.9, 1.0),
                 "decel_mps2_range": (0.8, 1.5), "max_jerk_mps3": 1.0},
}
#: Hard-launch acceleration limit at standstill [m/s²] and specific tractive power [W/kg] of ``launch`` segments.
LAUNCH_ACCEL_MPS2 = (1.4, 2.2)
LAUNCH_POWER_W_PER_KG = (9.0, 12.0)
#: Specific tractive power [W/kg] of ``motorway`` segments (on-ramps and overtaking), drawn per segment.
MOTORWAY_POWER_W_PER_KG = (8.0, 14.0)
#: Kinds of ``bus_mixed`` segments and their probabilities.
MIXED_KINDS = {"city": 0.35, "congested": 0.25, "launch": 0.2, "suburban": 0.2}
#: Payload range [kg] the training scenario draws under every family (``random_service``).
PAYLOAD_KG_RANGE = (0.0, 4500.0)


@dataclasses.dataclass(frozen=True)
class Plan:
    """What a family draws for one seed: segments ``(kind, duration_s)`` and the road's highest grade (or None)."""

    segments: list[tuple[str, int]]
    max_grade: float | None = None


def _plan_long(rng: np.random.Generator) -> Plan:
    total = int(rng.integers(3000, 4201))
    if rng.random() < 0.5:
        sub = int(rng.integers(600, 1201))
        first = int(rng.integers(600, total - sub - 600 + 1))
        return Plan([("city", first), ("suburban", sub), ("city", total - first - sub)])
    return Plan([("city", total)])


def _plan_mixed(rng: np.random.Generator) -> Plan:
    total = int(rng.integers(3000, 4501))
    n = int(rng.integers(3, 7))
    least = 400
    share = rng.dirichlet(np.ones(n)) * (total - least * n)
    lengths = [least + int(x) for x in share]
    lengths[-1] += total - sum(lengths)
    kinds = rng.choice(list(MIXED_KINDS), size=n, p=list(MIXED_KINDS.values()))
    max_grade = float(rng.uniform(0.03, 0.07)) if rng.random() < 0.5 else None  # hilly on half
    return Plan([(str(k), d) for k, d in zip(kinds, lengths)], max_grade)


def _plan_express(rng: np.random.Generator) -> Plan:
    total = int(rng.integers(1800, 3601))
    motorway = int(total * rng.uniform(0.6, 0.75))
    first = int(rng.integers(150, total - motorway - 150 + 1))
    max_grade = float(rng.uniform(0.02, 0.05)) if rng.random() < 0.5 else None  # hilly on half
    return Plan([("city", first), ("motorway", motorway), ("city", total - first - motorway)], max_grade)


#: Each family: its description and how it draws a :class:`Plan` from its parameter generator.
FAMILIES: dict[str, tuple[str, Callable[[np.random.Generator], Plan] | None]] = {
    "random_bus": ("generate_bus_cycle(seed) with its defaults: 1,300 s of city driving, flat", None),
    "bus_long": ("long city routes (3,000-4,200 s), half of them with a suburban stretch; flat", _plan_long),
    "bus_congested": ("low-speed stop-and-go traffic (1,200-2,400 s, creeps of 5-30 km/h); flat",
                      lambda rng: Plan([("congested", int(rng.integers(1200, 2401)))])),
    "bus_launch": ("city driving with hard launches (1.4-2.2 m/s²) and hard braking (1,200-2,000 s); flat",
                   lambda rng: Plan([("launch", int(rng.integers(1200, 2001)))])),
    "bus_hilly": ("city driving (1,200-2,400 s) over rolling hills, grades up to ±4-8 %, no net climb",
                  lambda rng: Plan([("city", int(rng.integers(1200, 2401)))], float(rng.uniform(0.04, 0.08)))),
    "bus_mixed": ("long routes (3,000-4,500 s) of city, congested, hard-launch and suburban segments; "
                  "hilly on half", _plan_mixed),
    "bus_express": ("express and intercity routes (1,800-3,600 s): city at both ends, 60-75 % motorway at "
                    "60-110 km/h with hard on-ramp accelerations; hilly on half", _plan_express),
}


def list_families() -> list[str]:
    """Names of the cycle families."""
    return list(FAMILIES)


def inner_seed(family: str, seed: int, part: int) -> int:
    """The seed of part ``part`` (0: the draws, 1...: segments, last: the road) of cycle ``family:seed``; the
    family's position in :data:`FAMILIES` is part of it (never reorder them)."""
    if not 0 <= part < _PARTS:
        raise ValueError(f"part must be in [0, {_PARTS}), got {part}")
    if family not in FAMILIES:
        raise ValueError(f"unknown cycle family {family!r}; families: {', '.join(FAMILIES)}")
    return _INNER_BASE + (int(seed) * _PARTS + list(FAMILIES).index(family)) * _PARTS + part


def training_seed(rng: np.random.Generator, family: str) -> int:
    """A seed for a fresh training cycle of ``family``: in ``[0, TRAINING_SEED_LIMIT)``, never a reserved one."""
    reserved = RESERVED_TRAINING_SEEDS.get(family, frozenset())
    while True:
        seed = int(rng.integers(TRAINING_SEED_LIMIT))
        if seed not in reserved:
            break
    assert seed < VALIDATION_SEED_BASE, "training seeds must stay below the validation seeds"
    return seed


def _segment_kwargs(kind: str, rng: np.random.Generator) -> dict[str, Any]:
    kwargs = dict(SEGMENT_KINDS[kind])
    if kind == "city":
        kwargs["cruise_speed_mode_kmh"] = round(float(rng.uniform(10.0, 20.0)), 3)
    elif kind == "launch":
        kwargs["max_accel_mps2"] = round(float(rng.uniform(*LAUNCH_ACCEL_MPS2)), 3)
        kwargs["accel_power_w_per_kg"] = round(float(rng.uniform(*LAUNCH_POWER_W_PER_KG)), 3)
    elif kind == "motorway":
        kwargs["accel_power_w_per_kg"] = round(float(rng.uniform(*MOTORWAY_POWER_W_PER_KG)), 3)
    return kwargs


def generate_family_cycle(family: str, seed: int, *, name: str | None = None) -> Cycle:
    """Cycle ``seed`` (a non-negative integer) of ``family`` (one of :func:`list_families`), always the same.

    ``name`` defaults to ``"FAMILY:SEED"``, which :func:`~hev_thermal_env.cycles.load_cycle` reloads. The cycle runs
    from and to standstill; its ``metadata`` holds the family, the seed, the segments (kind, duration, generator
    seed and arguments) and the road profile (seed and arguments).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed of a {family} cycle must be a non-negative integer, got {seed!r}")
    description, planner = FAMILIES.get(family, (None, None))
    if description is None:
        raise ValueError(f"unknown cycle family {family!r}; families: {', '.join(FAMILIES)}")
    label = name if name is not None else f"{family}:{int(seed)}"
    if planner is None:  # random_bus: the generator as it is
        cyc = generate_bus_cycle(int(seed))
        return dataclasses.replace(cyc, name=label, metadata={**cyc.metadata, "family": family})
    rng = np.random.default_rng(inner_seed(family, seed, 0))
    plan = planner(rng)
    speeds = [np.zeros(1)]
    segments = []
    for i, (kind, duration_s) in enumerate(plan.segments, start=1):
        kwargs = _segment_kwargs(kind, rng)
        seg_seed = inner_seed(family, seed, i)
        speeds.append(generate_bus_cycle(seg_seed, float(duration_s), **kwargs).speed_mps[1:])
        segments.append({"kind": kind, "duration_s": int(duration_s), "seed": seg_seed,
                         "params": as_lists(kwargs)})
    v = np.concatenate(speeds)
    road, grade = None, np.zeros(len(v))
    if plan.max_grade is not None:
        road_seed = inner_seed(family, seed, _PARTS - 1)
        kwargs = hill_kwargs(plan.max_grade)
        grade = grade_along(v, road_seed, **kwargs)
        road = {"seed": road_seed, "params": as_lists(kwargs)}
    metadata = {"synthetic": True, "generator": "hev_thermal_env.cycles.families.generate_family_cycle",
                "family": family, "seed": int(seed), "segments": segments, "grade_profile": road}
    return Cycle(name=label, time_s=np.arange(len(v), dtype=np.float64), speed_mps=v, grade=grade, synthetic=True,
                 description=f"Synthetic {family} cycle, seed {int(seed)}: {description} (generated, not measured)",
                 source=f"hev_thermal_env.cycles.generate_family_cycle({family!r}, {int(seed)})", metadata=metadata)


def cycle_statistics(cycle: Cycle) -> dict[str, float]:
    """What the family pages document of a cycle: duration, distance, speeds, ``stops_per_km`` (arrivals at
    standstill, below 0.1 m/s, per km), idling, ``max_accel_mps2`` / ``max_decel_mps2`` (the largest 1-s speed
    gain / loss) and grade."""
    v = np.asarray(cycle.speed_mps)
    a = np.diff(v)
    moving = v >= IDLE_SPEED_MPS
    stops = int(np.sum(moving[:-1] & ~moving[1:]))
    km = cycle.distance_km
    return {"duration_s": cycle.duration_s, "distance_km": km, "mean_speed_kmh": cycle.mean_speed_kmh,
            "max_speed_kmh": cycle.max_speed_kmh, "stops_per_km": stops / km if km > 0 else 0.0,
            "idle_fraction": cycle.idle_fraction, "max_accel_mps2": float(a.max()), "max_decel_mps2": float(-a.min()),
            "grade_min": float(np.min(cycle.grade)), "grade_max": float(np.max(cycle.grade))}
