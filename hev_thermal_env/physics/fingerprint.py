"""A fingerprint of the physics' behaviour: which physics a trained policy was trained on.

:func:`physics_fingerprint` drives the default vehicle through a fixed probe (motor shares, speeds and grades,
three steps each, at a cold and a hot motor) and hashes the outputs rounded to 6 significant digits: a change of
the physics' numbers changes it, editing comments, moving code or rounding noise across machines does not.
Training records it beside the model; loading a policy on physics with another fingerprint logs a warning.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from .config import Conditions, VehicleConfig, paper_bus
from .core import PhysicsCore

_SIGNIFICANT_DIGITS = 6


@functools.lru_cache(maxsize=4)
def physics_fingerprint(config: VehicleConfig | None = None) -> str:
    """16 hex digits identifying the physics behaviour of ``config`` (default ``paper_bus()``)."""
    core = PhysicsCore(config or paper_bus())
    u = np.linspace(-1.0, 1.0, 9)
    speeds = np.array([0.0, 3.0, 8.0, 15.0, 24.0])
    grades = np.array([-0.03, 0.0, 0.05])
    au, av, ag = (a.ravel() for a in np.meshgrid(u, speeds, grades, indexing="ij"))
    h = hashlib.sha256()
    for conditions in (Conditions(initial_soc=0.45), Conditions(initial_motor_temp_c=62.0, coolant="off")):
        state = core.initial_state(conditions, au.size)
        cond = core.conditions_array(conditions, au.size)
        for dv in (1.2, 0.0, -1.0):
            state, out = core.step(state, au, av, np.maximum(av + dv, 0.0), ag, cond)
            h.update(_rounded(out).tobytes())
            h.update(_rounded(state).tobytes())
    return h.hexdigest()[:16]


def _rounded(x: np.ndarray) -> np.ndarray:
    x = np.where(np.isfinite(x), x, 0.0)
    scale = 10.0 ** (_SIGNIFICANT_DIGITS - 1 - np.floor(np.log10(np.where(x == 0.0, 1.0, np.abs(x)))))
    return np.round(x * scale) / scale
