"""Names of generated cycles (docs/cycle-families.md, *Names*): one cycle (``FAMILY:SEED``, ``validation_bus:K``),
a bare family (a fresh cycle every episode in an env's or training run's cycle list), or a set (``validation_bus``,
``validation_bus:A..B``, ``FAMILY:A..B`` inclusive, at most :data:`MAX_RANGE` seeds), which :func:`expand_cycle_names`
replaces by its cycles' names wherever a list of cycles is accepted.

The validation set ``validation_bus``: cycle ``k`` has a family of :data:`VALIDATION_FAMILIES` in turn (from
:data:`ROTATION_SIZE` on :data:`EXPRESS_FAMILY`) and seed ``VALIDATION_SEED_BASE + k``, above every training seed
(:func:`validation_seed` asserts it); runs select checkpoints on ``validation_bus:20..29`` and are judged on
``validation_bus:0..19``.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
from typing import Any

from .cycle import Cycle
from .families import FAMILIES, TRAINING_SEED_LIMIT, VALIDATION_SEED_BASE, generate_family_cycle

#: The most cycles one ``FAMILY:A..B`` range may name.
MAX_RANGE = 1000

_ONE = re.compile(r"^([a-z_]+):(\d+)$")
_RANGE = re.compile(r"^([a-z_]+):(\d+)\.\.(\d+)$")

#: The name of the set (``validation_bus``: all; ``validation_bus:k``: one; ``validation_bus:a..b``: a range).
VALIDATION_SET = "validation_bus"
#: The families of the validation cycles, in turn.
VALIDATION_FAMILIES = ("bus_long", "bus_congested", "bus_launch", "bus_hilly", "bus_mixed")
#: Cycles ``0 .. ROTATION_SIZE - 1`` rotate through :data:`VALIDATION_FAMILIES`.
ROTATION_SIZE = 25
#: The family of the cycles from :data:`ROTATION_SIZE` on.
EXPRESS_FAMILY = "bus_express"
#: Number of validation cycles.
VALIDATION_SIZE = 30


def validation_seed(k: int) -> int:
    """The seed of validation cycle ``k`` (above every training seed)."""
    if not 0 <= int(k) < VALIDATION_SIZE:
        raise ValueError(f"{VALIDATION_SET}:{k}: the validation set has cycles 0-{VALIDATION_SIZE - 1}")
    seed = VALIDATION_SEED_BASE + int(k)
    assert seed >= TRAINING_SEED_LIMIT, "validation seeds must lie above every training seed"
    return seed


def validation_cycle(k: int) -> Cycle:
    """Validation cycle ``k``, named ``validation_bus:k``."""
    family = EXPRESS_FAMILY if int(k) >= ROTATION_SIZE else VALIDATION_FAMILIES[int(k) % len(VALIDATION_FAMILIES)]
    return generate_family_cycle(family, validation_seed(k), name=f"{VALIDATION_SET}:{int(k)}")


def validation_names(first: int = 0, last: int = VALIDATION_SIZE - 1) -> list[str]:
    """The names ``validation_bus:first`` ... ``validation_bus:last`` (inclusive)."""
    for k in (first, last):
        validation_seed(k)
    if last < first:
        raise ValueError(f"{VALIDATION_SET}:{first}..{last}: the range is empty (the first index is above the last)")
    return [f"{VALIDATION_SET}:{k}" for k in range(first, last + 1)]


def _key(name: str) -> str:
    return name.strip().lower()


def is_family(name: Any) -> bool:
    """Whether ``name`` is a bare family name (a fresh cycle per episode in a cycle list)."""
    return isinstance(name, str) and _key(name) in FAMILIES


def is_cycle_set(name: Any) -> bool:
    """Whether ``name`` names a set of cycles (``validation_bus``, ``validation_bus:A..B``, ``FAMILY:A..B``)."""
    if not isinstance(name, str):
        return False
    key = _key(name)
    m = _RANGE.match(key)
    return key == VALIDATION_SET or (m is not None and (m.group(1) == VALIDATION_SET or m.group(1) in FAMILIES))


def generated_cycle(name: str) -> Cycle | None:
    """The cycle named ``FAMILY:SEED`` or ``validation_bus:K``, or None if ``name`` is neither.

    Raises ``ValueError`` for a bare family name or a set (not one cycle) and for an index outside the
    validation set.
    """
    key = _key(name)
    if key in FAMILIES:
        raise ValueError(f"{name!r} is a family of generated cycles, not one cycle: name one as {key}:SEED "
                         f"(e.g. {key}:0), or list {key!r} as an env or training cycle for a fresh one per episode "
                         f"(generate_bus_cycle / generate_family_cycle)")
    if is_cycle_set(key):
        raise ValueError(f"{name!r} is a set of cycles ({VALIDATION_SET} holds {VALIDATION_SIZE}), not one cycle: "
                         f"pass it where a list of cycles is accepted, or name one cycle (FAMILY:SEED, "
                         f"{VALIDATION_SET}:K)")
    m = _ONE.match(key)
    if m is not None and (m.group(1) == VALIDATION_SET or m.group(1) in FAMILIES):
        return _generated(m.group(1), int(m.group(2)))
    return None


@functools.lru_cache(maxsize=128)
def _generated(family: str, seed: int) -> Cycle:
    """A named generated cycle, generated once per process: a :class:`Cycle` is immutable, and checking a training
    config loads every evaluation cycle it names (the validation set's 30 are generated in seconds)."""
    if family == VALIDATION_SET:
        return validation_cycle(seed)
    return generate_family_cycle(family, seed)


def expand_cycle_names(cycles: Any) -> list[Any]:
    """``cycles`` (one item or a list) with every set name replaced by the names of its cycles, in order
    (``["beijing", "validation_bus:0..2"]`` gives ``beijing`` and ``validation_bus:0`` to ``:2``); other items
    (built-in names, paths, ``FAMILY:SEED``, family names, :class:`Cycle` objects) pass through."""
    items: Iterable[Any] = cycles if isinstance(cycles, (list, tuple)) else [cycles]
    out: list[Any] = []
    for item in items:
        if not is_cycle_set(item):
            out.append(item)
        elif (m := _RANGE.match(_key(item))) is None:
            out += validation_names()
        else:
            prefix, first, last = m.group(1), int(m.group(2)), int(m.group(3))
            if prefix == VALIDATION_SET:
                out += validation_names(first, last)
            elif not 0 < last - first + 1 <= MAX_RANGE:
                raise ValueError(f"{item!r}: a range of seeds must name 1 to {MAX_RANGE} cycles (first <= last)")
            else:
                out += [f"{prefix}:{seed}" for seed in range(first, last + 1)]
    return out
