"""The protocol every strategy follows, so evaluation treats PPO, rules, ECMS and DP alike.

A strategy is driven through ``HevThermal-v1``::

    strategy.reset(env)            # once per episode, after env.reset(); may plan (DP)
    action = strategy.act(obs, info)   # every step; returns np.ndarray of shape (1,)

``env_options()`` gives the env arguments a strategy drives with that leave the episode, the physics and the score as
they are (a trained policy's observation settings); ``vehicle_config(config)`` lets a strategy change the vehicle it
drives (``conventional``). A strategy is one module: its class carries its facts (:class:`Strategy`'s class
attributes) and registers itself with :func:`register`, so the registry, the benchmark, the leaderboard, the figures
and imitation know it with nothing else changed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.physics import VehicleConfig


class Strategy:
    """Base class: subclasses override :meth:`act` and optionally :meth:`reset`; the class attributes are the facts
    the rest of the package reads (from the registry, :func:`registered`)."""

    #: The name ``get_strategy`` takes.
    name: str = "strategy"
    #: The place in listings, tables and figures, the simplest first (the optimum and learned policies last).
    order: float = 1000.0
    #: Its colour in every figure; None: one of the other strategies' colours, in turn.
    colour: str | None = None
    #: Its line style in figures (None: solid, unless drawn as a learned policy).
    line_style: str | None = None
    #: Added to its name wherever tables and figures show it (``dp``: thermal-blind).
    label_suffix: str = ""
    #: Its name on the leaderboard's page, if not its name with :attr:`label_suffix`.
    leaderboard_label: str | None = None
    #: It respects the thermal model.
    thermal_aware: bool = False
    #: It drives another vehicle (its rows are not compared with the hybrid's optimum).
    other_vehicle: bool = False
    #: A learned policy (drawn in warm colours with thicker lines, after the others).
    learned: bool = False
    #: An optimum (a plan over the whole cycle: drawn after the step-by-step strategies).
    optimum: bool = False
    #: A step-by-step strategy an imitation start can learn from (``init.imitate``).
    teacher: bool = False
    #: Run by the default benchmark (``evaluate.py benchmark``) and, unless it drives another vehicle, the
    #: leaderboard.
    in_benchmark: bool = False
    #: Expected seconds of a run per second of cycle on one core, and besides its steps (building the strategy and
    #: the environment): the benchmark's progress estimate.
    seconds_per_step: float = 1e-4
    overhead_s: float = 0.2

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


_REGISTRY: dict[str, type[Strategy]] = {}


def register(cls: type[Strategy]) -> type[Strategy]:
    """Class decorator: ``get_strategy(cls.name)`` builds ``cls``; another class under a taken name raises
    ``ValueError`` (the same class imported again replaces itself)."""
    old = _REGISTRY.get(cls.name)
    if old is not None and old.__qualname__ != cls.__qualname__:
        raise ValueError(f"strategy name {cls.name!r} is taken by {old.__module__}.{old.__qualname__}")
    _REGISTRY[cls.name] = cls
    return cls


def registered() -> list[type[Strategy]]:
    """The registered strategy classes by :attr:`Strategy.order` (then name)."""
    return sorted(_REGISTRY.values(), key=lambda c: (c.order, c.name))


def strategy_class(name: str) -> type[Strategy] | None:
    """The class of a registered strategy by name (the part before any ``:``), or None."""
    return _REGISTRY.get(str(name).split(":", 1)[0])
