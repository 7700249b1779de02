"""Adapters of the envs to other libraries' interfaces, imported on demand.

* :class:`Sb3VecEnv` (``hev_thermal_env.wrappers.sb3``): the native vector env as a
  Stable-Baselines3 ``VecEnv`` (imports stable-baselines3 and torch when first used).
"""

from __future__ import annotations

from typing import Any

__all__ = ["Sb3VecEnv"]


def __getattr__(name: str) -> Any:
    if name == "Sb3VecEnv":
        from .sb3 import Sb3VecEnv

        return Sb3VecEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
