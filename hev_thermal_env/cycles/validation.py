"""The validation set ``validation_bus``: fixed generated bus cycles that training never draws.

Cycle ``k`` (``validation_bus:k``) has family :func:`validation_family` (below :data:`ROTATION_SIZE` the five of
:data:`VALIDATION_FAMILIES` in turn, then express routes) and seed ``VALIDATION_SEED_BASE + k``, above every
training seed (:func:`validation_seed` asserts it). A training run selects its checkpoints on
``validation_bus:20..29``; the trained policies are judged on ``validation_bus:0..19``, which no selection saw.
"""

from __future__ import annotations

from .cycle import Cycle
from .families import TRAINING_SEED_LIMIT, VALIDATION_SEED_BASE, generate_family_cycle

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


def validation_family(k: int) -> str:
    """The family of validation cycle ``k``."""
    return EXPRESS_FAMILY if int(k) >= ROTATION_SIZE else VALIDATION_FAMILIES[int(k) % len(VALIDATION_FAMILIES)]


def validation_cycle(k: int) -> Cycle:
    """Validation cycle ``k``, named ``validation_bus:k``."""
    return generate_family_cycle(validation_family(k), validation_seed(k), name=f"{VALIDATION_SET}:{int(k)}")


def validation_names(first: int = 0, last: int = VALIDATION_SIZE - 1) -> list[str]:
    """The names ``validation_bus:first`` ... ``validation_bus:last`` (inclusive)."""
    for k in (first, last):
        validation_seed(k)
    if last < first:
        raise ValueError(f"{VALIDATION_SET}:{first}..{last}: the range is empty (the first index is above the last)")
    return [f"{VALIDATION_SET}:{k}" for k in range(first, last + 1)]
