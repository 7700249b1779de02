"""Native batched vector form of ``HevThermal-v2``: n sub-environments stepped by one call of the batch engine.

Sub-environment ``i`` reset with seed ``s`` lives through exactly the trajectory of ``HevThermalEnv`` reset with seed
``s``: both step through :class:`~hev_thermal_env.envs.batch.EpisodeRows`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..physics.config import Conditions, VehicleConfig
from ..scenarios import Scenario
from .batch import EnvParts
from .reward import RewardParams
from .spaces import EPISODE_INFO_KEYS, INFO_DTYPES, step_info

# Attributes with one value per sub-environment (``get_attr`` returns them per env; they cannot be set).
_PER_ENV_ATTRS = {
    "cycle": lambda env, i: env._rows.cycles[i], "conditions": lambda env, i: env._rows.conditions[i],
    "k": lambda env, i: int(env._rows.k[i]), "soc_target": lambda env, i: float(env._rows.soc_target[i]),
    "phys_state": lambda env, i: env._rows.state[i:i + 1].copy(),
    "cond": lambda env, i: env._rows.cond[i:i + 1].copy(),
    "last_out": lambda env, i: env._rows.last_out[i].copy(), "np_random": lambda env, i: env._rngs[i],
}


class HevThermalVectorEnv(EnvParts, VectorEnv):
    """``num_envs`` copies of ``HevThermal-v2`` stepped together by one batched call of the physics core.

    Arguments are those of :class:`~hev_thermal_env.envs.HevThermalEnv` (shared by all sub-environments; ``render_mode``
    must be None: render single envs), plus ``max_episode_steps`` (optional cap on an episode's steps, per sub-env) and
    ``autoreset_mode`` (:class:`gymnasium.vector.AutoresetMode` or its value):

    ``NEXT_STEP`` (default, as gymnasium 1.x: the step after a truncation resets that sub-env, ignores its action and
    returns reward 0 and the reset's info), ``SAME_STEP`` (a truncating sub-env resets within the same step;
    ``infos["final_obs"]`` and ``infos["final_info"]`` hold the last step's; the SB3 adapter uses it) or ``DISABLED``
    (stepping an ended sub-env raises; reset it with ``reset(options={"reset_mask": mask})``).

    Each sub-env truncates at the end of its own cycle. ``reset(seed=s)`` seeds sub-env ``i`` with ``s + i`` (a list
    seeds each one), each with its own generator made as the single env's. ``reset(options=...)`` takes the single
    env's options for every reset sub-env, ``reset_mask`` (reset only these), or a list of one dict per sub-env.

    Infos are dicts of arrays with ``_key`` masks (gymnasium's vector format), with the single env's keys and values,
    one array of dtype :data:`~hev_thermal_env.envs.spaces.INFO_DTYPES` per key; resets and steps report the same keys
    (torchrl reads it in the ``SAME_STEP`` and ``DISABLED`` modes). The batch attributes ``config``, ``core``,
    ``reward_params``, ``cycles``, ``conditions``, ``k`` [n], ``phys_state`` [n, N_STATE], ``cond`` [n, N_COND],
    ``soc_target`` [n] and ``last_out`` [n, N_OUT] mirror the single env's.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, *, cycle: Any = "hwfet", scenario: str | Scenario = "paper",
                 config: VehicleConfig | None = None, conditions: Conditions | None = None,
                 reward: RewardParams | dict | None = None, preview_s: int = 10, preview_step_s: int = 2,
                 thermal: bool | None = None, random_start: bool = False, max_episode_steps: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, render_mode: str | None = None,
                 info_keys: str | Sequence[str] = "all", soc_offset: float = 0.0, physics: int = 2):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError("HevThermalVectorEnv does not render; use render_mode=None (render single envs instead)")
        if max_episode_steps is not None and (int(max_episode_steps) != max_episode_steps or max_episode_steps < 1):
            raise ValueError(f"max_episode_steps must be a positive integer or None, got {max_episode_steps!r}")
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode}
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.single_observation_space, self.single_action_space = self._build(
            self.num_envs, cycle, scenario, config, conditions, reward, preview_s, preview_step_s, thermal,
            random_start, info_keys, soc_offset, physics)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._started = np.zeros(self.num_envs, dtype=bool)
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._episode_cols = {key: np.zeros(self.num_envs, dtype=INFO_DTYPES[key]) for key in EPISODE_INFO_KEYS}

    cycles = property(lambda self: list(self._rows.cycles))
    conditions = property(lambda self: list(self._rows.conditions))
    k = property(lambda self: self._rows.k.copy())
    soc_target = property(lambda self: self._rows.soc_target)
    last_out = property(lambda self: self._rows.last_out)

    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | Sequence[dict[str, Any] | None] | None = None):
        seeds = self._seed_list(seed)
        mask = np.ones(self.num_envs, dtype=bool)
        per_env: list[dict | None]
        if isinstance(options, dict):
            options = dict(options)
            if "reset_mask" in options:
                mask = options.pop("reset_mask")
                if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
                    raise ValueError(f"options['reset_mask'] must be a numpy bool array of shape ({self.num_envs},)")
                if not mask.any():
                    raise ValueError("options['reset_mask'] must select at least one sub-environment")
            per_env = [options] * self.num_envs
        elif options is None:
            per_env = [None] * self.num_envs
        else:
            per_env = list(options)
            if len(per_env) != self.num_envs:
                raise ValueError(f"options: a list needs one dict per sub-environment ({self.num_envs}), "
                                 f"got {len(per_env)}")
        if isinstance(seed, int) and not isinstance(seed, bool):
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        idx = np.flatnonzero(mask)
        for i in idx:  # a new generator where a seed is given (or none exists yet), made as the single env's
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        reset_infos = self._start_episodes(idx, [per_env[i] for i in idx])
        self._autoreset[idx] = False
        return self._rows.observe(), self._reset_info_arrays(idx, reset_infos, {})

    def step(self, actions: np.ndarray):
        u, clipped = self._check_actions(actions)
        rows = self._rows
        if not self._started.all():
            raise RuntimeError("call reset() before step()")
        mode = self.autoreset_mode
        if mode == AutoresetMode.DISABLED and np.any(rows.k >= rows.end):
            ended = np.flatnonzero(rows.k >= rows.end)
            raise RuntimeError(f"sub-environment(s) {ended.tolist()} have ended and autoreset is disabled; "
                               "reset them with reset(options={'reset_mask': mask})")
        resetting = np.flatnonzero(self._autoreset) if mode == AutoresetMode.NEXT_STEP else np.empty(0, np.int64)
        u[resetting] = 0.0  # the step after a truncation only resets
        clipped[resetting] = False
        reward, terms, out, obs = rows.step(u)
        state = rows.state
        truncated = rows.k >= rows.end
        terminated = np.zeros(self.num_envs, dtype=bool)
        cycle_speed = rows.speed[rows.all_rows, rows.k]  # before any reset (which may widen the tables)
        time_s = rows.k.astype(np.float64)
        step_mask = np.ones(self.num_envs, dtype=bool)
        if resetting.size:
            reset_infos = self._start_episodes(resetting, [None] * resetting.size)  # new state array, out rows zeroed
            for arr in (out, state, reward, cycle_speed, time_s, terms):
                arr[resetting] = 0.0
            truncated[resetting] = False
            step_mask[resetting] = False
        infos = self._step_infos(out, state, terms, cycle_speed, time_s, u, clipped, step_mask)
        if resetting.size:
            infos = self._reset_info_arrays(resetting, reset_infos, infos)
            obs = rows.observe()
        elif mode == AutoresetMode.SAME_STEP and truncated.any():
            idx = np.flatnonzero(truncated)
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in idx:
                final_obs[i] = obs[i].copy()
            done_mask = truncated.copy()
            final_info = {key: done_mask if key.startswith("_") else value for key, value in infos.items()}
            rows.last_out = out.copy()  # the final infos keep viewing ``out``
            reset_infos = self._start_episodes(idx, [None] * idx.size)
            obs[idx] = rows.observe(idx)
            infos = self._reset_info_arrays(idx, reset_infos, dict(infos))
            infos.update(final_obs=final_obs, _final_obs=done_mask, final_info=final_info, _final_info=done_mask)
        self._autoreset = terminated | truncated
        return obs, reward, terminated, truncated, infos

    def get_attr(self, name: str) -> tuple:
        """The attribute of every sub-environment: per-env values for the episode attributes
        (``cycle``, ``conditions``, ``k``, ``soc_target``, ``phys_state``, ``cond``, ``last_out``, ``np_random``), else
        the shared attribute of the vector env repeated."""
        if name in _PER_ENV_ATTRS:
            return tuple(_PER_ENV_ATTRS[name](self, i) for i in range(self.num_envs))
        return (getattr(self, name),) * self.num_envs

    def set_attr(self, name: str, values: Any) -> None:
        """Set a shared attribute (e.g. ``reward_params``); a list must hold the same value for every env."""
        if name in _PER_ENV_ATTRS:
            raise ValueError(f"{name!r} is per sub-environment and set by reset (options), not set_attr")
        if isinstance(values, (list, tuple)):
            if len(values) != self.num_envs:
                raise ValueError(f"set_attr: expected {self.num_envs} values, got {len(values)}")
            if any(v is not values[0] and v != values[0] for v in values[1:]):
                raise ValueError(f"set_attr: {name!r} is shared by all sub-environments; per-env values differ")
            values = values[0]
        if not hasattr(self, name):
            raise AttributeError(f"HevThermalVectorEnv has no attribute {name!r}")
        setattr(self, name, values)

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple:
        """Call a method of the vector env once (or read an attribute); the result for every sub-env."""
        attr = getattr(self, name)
        return (attr(*args, **kwargs) if callable(attr) else attr,) * self.num_envs

    def render(self):
        gym.logger.warn("HevThermalVectorEnv does not render; render a single HevThermal-v2 env instead")
        return None

    def __repr__(self) -> str:
        return f"HevThermalVectorEnv(num_envs={self.num_envs}, autoreset_mode={self.autoreset_mode.value})"

    def _seed_list(self, seed: Any) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed: a list needs one seed per sub-environment ({self.num_envs}), got {len(seeds)}")
        return seeds

    def _check_actions(self, actions: Any) -> tuple[np.ndarray, np.ndarray]:
        a = np.asarray(actions)
        if a.shape != (self.num_envs, 1):
            raise ValueError(f"actions must have shape ({self.num_envs}, 1) (num_envs, 1), got shape {a.shape}")
        raw = a[:, 0].astype(np.float64)
        if not np.isfinite(raw).all():
            bad = np.flatnonzero(~np.isfinite(raw))
            raise ValueError(f"actions must be finite; NaN or inf for sub-environment(s) {bad.tolist()}")
        u = np.clip(raw, -1.0, 1.0)
        return u, u != raw

    def _start_episodes(self, idx: np.ndarray, options: Sequence[dict | None]) -> list[dict]:
        """Draw and start new episodes in rows ``idx`` from their own generators; their reset infos."""
        infos = self._start(idx, [self._rngs[i] for i in idx], options, self.max_episode_steps)
        self._started[idx] = True
        for key, col in self._episode_cols.items():
            col[idx] = [info[key] for info in infos]
        return infos

    def _step_infos(self, out, state, terms, cycle_speed, time_s, u, clipped, mask) -> dict[str, np.ndarray]:
        if not self.info_keys:
            return {}
        episode = {key: col.copy() for key, col in self._episode_cols.items()}
        arrays = step_info(out.T, state.T, terms.T, cycle_speed, time_s, u, clipped, episode, self._cost_step_s)
        return {k: v for key in self.info_keys for k, v in ((key, arrays[key]), ("_" + key, mask))}

    def _reset_info_arrays(self, idx: np.ndarray, reset_infos: list[dict], infos: dict) -> dict:
        """``infos`` with the reset infos of sub-envs ``idx`` written into fresh arrays (the step's arrays may view the
        engine's outputs or be a final info's) and masked in."""
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[idx] = True
        for key in self.info_keys:
            values = [ri[key] for ri in reset_infos]
            if key in infos:
                infos[key], infos["_" + key] = infos[key].copy(), infos["_" + key] | mask
            else:
                infos[key], infos["_" + key] = np.zeros(self.num_envs, dtype=INFO_DTYPES[key]), mask.copy()
            infos[key][idx] = values
        return infos
