"""Learning-rate and clip-range schedules of the hyperparameter files (``lin_3e-4``).

SB3 pickles the schedule object into every model zip by its import path. Loading a model rebuilds
the schedules from the run's hyperparameters instead (:func:`custom_objects`, the same values), so a
policy loads without unpickling code of the training room.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: Hyperparameters that may be schedules.
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")


class LinearSchedule:
    """``progress_remaining`` (1 -> 0) times the initial value; picklable (saved inside the model)."""

    def __init__(self, initial: float):
        self.initial = float(initial)

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.initial

    def __repr__(self) -> str:
        return f"lin_{self.initial:g}"


def schedule(value: Any) -> Any:
    """``"lin_3e-4"`` -> a linear decay from 3e-4 to 0 over training; numbers stay constants."""
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            initial = float(value[4:])
        except ValueError:
            raise ValueError(f"schedule {value!r}: expected lin_<number>, e.g. lin_3e-4") from None
        return LinearSchedule(initial)
    return value


def custom_objects(hyperparams: Mapping[str, Any] | None) -> dict[str, Any]:
    """``custom_objects`` for SB3's ``load``: the schedules of a run, rebuilt from its hyperparameters.

    ``lr_schedule`` is recomputed by SB3 from ``learning_rate`` on loading; it is replaced only so
    that the saved one is not unpickled."""
    hp = hyperparams or {}
    objects = {key: schedule(hp[key]) for key in SCHEDULE_KEYS if key in hp}
    if "learning_rate" in objects:
        objects["lr_schedule"] = objects["learning_rate"]
    return objects
