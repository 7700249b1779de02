"""``ppo``: a policy trained by ``train.py`` (any of its algorithms), behind the strategy protocol.

``get_strategy("ppo")`` loads the policy shipped in ``agents/policies/ppo_default/``; ``"ppo:PATH"`` or ``path=PATH`` a
run directory or model zip of ``train.py`` (:func:`.policy_files.load_policy`). It acts deterministically on
observations normalised with the saved statistics; an env whose observation differs from the one the model was trained
on (e.g. another ``preview_s`` or ``descent_recovery``) raises ``ValueError`` naming what differs.
:meth:`PPOStrategy.env_options` gives the env the policy's ``descent_recovery`` (with
:func:`~hev_thermal_env.tasks.make_task` pass ``**strategy.env_options()``; the episodes and their score do not depend
on it). A recurrent policy's state starts afresh at every :meth:`PPOStrategy.reset`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import OBSERVED_REWARD_FIELDS, RewardParams, observation_options

from .base import Strategy, register
from .policy_files import LoadedPolicy, load_policy

DEFAULT_POLICY_DIR = Path(__file__).resolve().parent / "policies" / "ppo_default"
"""The shipped default policy (``get_strategy("ppo")``)."""


def trained_reward(policy: LoadedPolicy) -> RewardParams:
    """The reward the policy was trained on: its run config's ``env.reward`` over the env's defaults."""
    return RewardParams.of(dict(policy.env_settings.get("reward") or {}))


def observation_mismatch(policy: LoadedPolicy, env: Any) -> str | None:
    """Why ``env``'s observation differs from the one ``policy`` was trained on, or None."""
    e = env.unwrapped
    env_dim = int(e.observation_space.shape[0])
    settings = policy.env_settings
    env_preview = (int(getattr(e, "preview_s", -1)), int(getattr(e, "preview_step_s", -1)))
    saved_preview = (settings.get("preview_s"), settings.get("preview_step_s"))
    differences = []
    if env_dim != policy.obs_dim:
        differences.append(f"the model expects {policy.obs_dim} observation entries, the env gives {env_dim}")
    if None not in saved_preview and tuple(int(x) for x in saved_preview) != env_preview:
        differences.append(f"trained with preview_s={saved_preview[0]}, preview_step_s={saved_preview[1]}; the env "
                           f"has preview_s={env_preview[0]}, preview_step_s={env_preview[1]}")
    trained_reward_params = trained_reward(policy)
    for name in OBSERVED_REWARD_FIELDS:
        trained, here = getattr(trained_reward_params, name), getattr(e.reward_params, name)
        if trained != here:
            differences.append(f"the observation was trained with {name}={trained}; the env has {here}; build the "
                               f"env with reward={{'{name}': {trained}}} (PPOStrategy.env_options())")
    names = settings.get("observation_names")
    env_names = getattr(e, "obs_names", None)
    if not differences and names and env_names and list(names) != list(env_names):
        first = next(i for i, (a, b) in enumerate(zip(names, env_names)) if a != b)
        differences.append(f"observation entry {first} is {names[first]!r} in training and {env_names[first]!r} here")
    if not differences:
        return None
    where = policy.path if policy.path is not None else "the model"
    return f"ppo: {where} does not match this environment: " + "; ".join(differences)


@register
class PPOStrategy(Strategy):
    """A policy trained by ``train.py``; deterministic actions on normalised observations.

    Options: ``path`` (run directory or model zip; default the shipped ``ppo_default``) and ``normalize`` (False for a
    model trained without observation normalisation).
    """

    name = "ppo"
    order = 90
    leaderboard_label = "ppo (shipped policy)"
    learned = True
    in_benchmark = True
    overhead_s = 8.0  # loads torch in its worker first

    def __init__(self, path: str | Path | None = None, normalize: bool = True):
        self.policy = load_policy(DEFAULT_POLICY_DIR if path is None else path, normalize=normalize)
        env_cfg = self.policy.env_settings
        self.thermal_aware = bool(env_cfg.get("thermal", True)) and env_cfg.get("scenario", "paper") != "paper"
        self._obs = np.empty((1, self.policy.obs_dim), dtype=np.float32)

    @classmethod
    def from_label(cls, label: str, **options: Any) -> PPOStrategy:
        """``get_strategy("ppo:PATH")``: the text after the colon is the model path."""
        if "path" in options:
            raise ValueError(f"ppo: give the model either as 'ppo:{label}' or as path=..., not both")
        strategy = cls(path=label, **options)
        strategy.label = f"ppo:{label}"
        return strategy

    def env_options(self) -> dict[str, Any]:
        """The observation's reward arguments as in training (:func:`~hev_thermal_env.envs.reward.observation_options`
        of the run config's ``env.reward``)."""
        return observation_options(self.policy.env_settings.get("reward"))

    def reset(self, env: Any) -> None:
        super().reset(env)
        self.policy.reset_state()
        if problem := observation_mismatch(self.policy, env):
            raise ValueError(problem)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        self._obs[0] = obs
        return self.policy.act(self._obs)[0]

    def describe(self) -> dict[str, Any]:
        cfg = self.policy.config or {}
        env_cfg = self.policy.env_settings
        return {
            "model": str(self.policy.path), "algo": cfg.get("algo", "ppo"), "seed": cfg.get("seed"),
            "total_timesteps": cfg.get("total_timesteps"), "train_cycles": env_cfg.get("cycles"),
            "train_scenario": env_cfg.get("scenario"), "preview_s": env_cfg.get("preview_s"),
            "preview_step_s": env_cfg.get("preview_step_s"), "normalized_obs": self.policy.stats is not None,
            "imitate": (cfg.get("init") or {}).get("imitate"),
        }

