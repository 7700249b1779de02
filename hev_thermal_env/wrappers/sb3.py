"""Stable-Baselines3 ``VecEnv`` over the native vector env: SB3 trains on the batched core (importing this
module imports stable-baselines3 and torch; ``import hev_thermal_env`` does not)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv

from ..envs.vector_env import HevThermalVectorEnv


class Sb3VecEnv(VecEnv):
    """SB3 ``VecEnv`` over :class:`~hev_thermal_env.envs.HevThermalVectorEnv` in ``SAME_STEP`` autoreset mode.

    SB3 semantics: a sub-environment that ends is reset in the same step; ``infos[i]["terminal_observation"]`` holds
    its last observation, ``infos[i]["TimeLimit.truncated"]`` says whether the end was a truncation (always, here) and
    ``reset_infos[i]`` the new episode's reset info. ``seed()`` and ``set_options()`` apply at the next ``reset()``.
    ``info_keys`` selects the info keys copied into SB3's info dicts (``()`` is fastest: PPO and ``VecMonitor`` need no
    others). ``set_attr`` sets a shared attribute (all indices at once); ``env_method`` calls the vector env's once.
    """

    def __init__(self, num_envs: int, *, info_keys: str | Sequence[str] = "all", **env_kwargs: Any):
        self.venv = HevThermalVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, info_keys=info_keys,
                                        **env_kwargs)
        self.info_keys = self.venv.info_keys
        self._actions: np.ndarray | None = None
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)

    def reset(self) -> np.ndarray:
        seeds = self._seeds if any(s is not None for s in self._seeds) else None
        options = list(self._options) if any(self._options) else None
        obs, infos = self.venv.reset(seed=seeds, options=options)
        keys = self.info_keys
        self.reset_infos = [{key: _item(infos[key][i]) for key in keys} for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, reward, terminated, truncated, infos = self.venv.step(self._actions)
        keys = self.info_keys
        columns = zip(*[infos[key].tolist() for key in keys]) if keys else [()] * self.num_envs
        dicts = [dict(zip(keys, values)) for values in columns]
        for d in dicts:
            d["TimeLimit.truncated"] = False
        dones = terminated | truncated
        if dones.any():
            final = infos["final_info"]
            for i in np.flatnonzero(dones):
                d = {key: _item(final[key][i]) for key in keys}
                d["terminal_observation"] = infos["final_obs"][i]
                d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                dicts[i] = d
                self.reset_infos[i] = {key: _item(infos[key][i]) for key in keys}
        return obs, reward.astype(np.float32), dones, dicts

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        if sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(f"set_attr: {attr_name!r} is shared by all sub-environments; set it for all indices")
        self.venv.set_attr(attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        result = self.venv.call(method_name, *method_args, **method_kwargs)
        return [result[i] for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> list[None]:
        return [None] * self.num_envs


def _item(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value
