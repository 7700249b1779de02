"""Test helpers of the training room."""

from __future__ import annotations

from typing import Any

from hev_thermal_env.training.imitation import InitConfig


def check_init(init: dict[str, Any], algo: str, names: tuple[str, ...] | list[str] = ()) -> dict[str, Any]:
    """The ``init`` section completed with its defaults, checked for the run (:meth:`InitConfig.for_run`)."""
    return InitConfig.from_dict(init).for_run(algo, names).to_dict()
