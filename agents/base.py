"""The protocol every strategy follows, so evaluation treats PPO, rules, ECMS and DP alike.

A strategy is driven through ``HevThermal-v1``::

    strategy.reset(env)            # once per episode, after env.reset(); may plan (DP)
    action = strategy.act(obs, info)   # every step; returns np.ndarray of shape (1,)

``env_options()`` gives the env arguments a strategy drives with that leave the episode, the physics and the score as
they are (a trained policy's observation settings); ``vehicle_config(config)`` lets a strategy change the vehicle it
drives (``conventional`` drives the conventional bus,
and says so with ``other_vehicle``: its rows are not compared with the hybrid's optimum); ``thermal_aware`` says whether
it respects the thermal model.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.physics import VehicleConfig


class Strategy:
    """Base class: subclasses override :meth:`act` and optionally :meth:`reset`."""

    name: str = "strategy"
    thermal_aware: bool = False
    other_vehicle: bool = False

    def vehicle_config(self, config: VehicleConfig) -> VehicleConfig:
        return config

    def env_options(self) -> dict[str, Any]:
        """Keyword arguments of ``HevThermalEnv`` this strategy is driven with; none by default."""
        return {}

    def reset(self, env: Any) -> None:
        """Called after ``env.reset()``; ``env.unwrapped`` exposes the physics (see the env's docs)."""
        self.env = env.unwrapped

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """Settings worth reporting next to the results (grid sizes, gains...)."""
        return {}
