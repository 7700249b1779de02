"""The observation of the batch engine's rows (:func:`observe_kernel`), fused into every step of both envs.

A module of its own so that nothing that plans (DP, the thermal optimum) depends on it.
"""

from __future__ import annotations

from ..physics import core
from ..physics.jit import jit
from . import spaces
from .reward import band_center


@jit
def observe_kernel(w, rows, k, state, cond, soc_target, avail, n_steps, speed, demand, gear, descent, offsets, dt_s,
                   low, high, obs):
    """Observations of ``rows`` into ``obs`` [len(rows), dim] (float32, clipped to [low, high]), in the order of
    :func:`~hev_thermal_env.envs.spaces.observation_names`; the band's center from ``descent`` and the weights ``w``."""
    n_base = spaces.N_OBS_BASE
    for i in range(rows.shape[0]):
        r = rows[i]
        j = k[r]
        v0 = speed[r, j]
        obs[i, spaces.OBS_SPEED] = v0
        obs[i, spaces.OBS_ACCEL] = (speed[r, j + 1] - v0) / dt_s
        obs[i, spaces.OBS_DEMAND] = demand[r, j]
        obs[i, spaces.OBS_SOC] = state[r, core.SOC]
        center = band_center(w, soc_target[r], descent[r, j])
        obs[i, spaces.OBS_SOC_TARGET] = center
        obs[i, spaces.OBS_SOC_DEVIATION] = state[r, core.SOC] - center
        obs[i, spaces.OBS_TEMP] = state[r, core.TEMP_C]
        obs[i, spaces.OBS_WINDING] = state[r, core.WINDING_C]
        obs[i, spaces.OBS_PWM] = state[r, core.HEAT_X]  # PWM = clip(x, 0, 1): the bounds below clip it
        obs[i, spaces.OBS_HEAT_X] = state[r, core.HEAT_X]
        # either protection stops the motor
        obs[i, spaces.OBS_CUTOFF] = max(state[r, core.CUTOFF], state[r, core.WINDING_TRIP])
        obs[i, spaces.OBS_AVAIL] = avail[r]
        obs[i, spaces.OBS_GEAR] = gear[r, j]
        obs[i, spaces.OBS_PROGRESS] = j / n_steps[r]
        obs[i, spaces.OBS_AMBIENT] = cond[r, core.AMBIENT_C]
        obs[i, spaces.OBS_COOLANT] = cond[r, core.COOLANT_FACTOR]
        for p in range(offsets.shape[0]):
            obs[i, n_base + p] = speed[r, j + offsets[p]]
        for c in range(obs.shape[1]):
            x = obs[i, c]
            if x < low[c]:
                obs[i, c] = low[c]
            elif x > high[c]:
                obs[i, c] = high[c]
