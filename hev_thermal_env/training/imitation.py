"""A new PPO run's starting point: the policy imitates a classic strategy (behaviour cloning), then PPO learns.

:func:`imitate`: the teacher (``init.imitate``) drives ``init.episodes`` episodes of the training env
(:func:`demonstrations`), the ``VecNormalize`` statistics start from them, and the policy's mean action is fitted to
the teacher's (:mod:`.fit`); the value function is not pretrained. :class:`DemonstrationRefit` goes on fitting during
PPO (``init.refit_batches``, DAgger with ``init.dagger_every``). Each setting and why: docs/training.md.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.running_mean_std import RunningMeanStd
from tqdm.auto import tqdm

from hev_thermal_env.agents import get_strategy, registered
from hev_thermal_env.agents.base import Strategy
from hev_thermal_env.agents.policy_files import LoadedPolicy
from hev_thermal_env.envs import HevThermalEnv

from ..envs.spaces import observation_names
from .fit import (
    BATCH,
    adam_step,
    batch_loss,
    fit_policy_mean,
    fit_targets,
    fit_weights,
    mean_cost_excess_g,
    near_derating,
)
from .hyperparams import Section, setting

#: The algorithms whose policy the imitation fits (PPO's feed-forward Gaussian policy).
IMITATING_ALGORITHMS = ("ppo", "ppo_lagrangian")
#: An entry whose variance over the demonstrations is at most this the teacher never moves (``ecms_thermal`` with its
#: fixed heat-index price never derates); ``init.freeze_obs_stats: true`` leaves its statistics to PPO's states.
MIN_FROZEN_VAR = 1e-12


@dataclasses.dataclass(frozen=True)
class InitConfig(Section):
    """The ``init`` section: the imitation start (module docstring); none unless the hyperparameter file asks for it.
    :meth:`for_run` adds the checks that need the run (its algorithm and observations)."""

    NAME: ClassVar[str] = "init"

    imitate: str | None = setting(None, "the teacher, a step-by-step classic strategy (null: start from scratch)")
    teacher_options: dict[str, Any] | None = setting({}, "the teacher's options (get_strategy; null: its defaults)")
    episodes: int = setting(60, "demonstration episodes driven by the teacher", kind="whole", min=1)
    epochs: int = setting(30, "passes of the fit over the demonstrations", kind="whole", min=0)
    beyond_bound: float = setting(0.25, "fit target beyond the upper bound where the teacher sits at it",
                                  kind="number", min=0.0, max=1.0)
    noise: float = setting(0.0, "noise on the driven action", kind="number", min=0.0, max=1.0,
                           what=" (the spread of the driven action)")
    freeze_obs_stats: bool | list[str] = setting(False, "observation statistics kept at the demonstrations'")
    refit_batches: int = setting(0, "batches of the demonstrations fitted again after every rollout", kind="whole",
                                 min=0)
    refit_lr: float = setting(1e-4, "the refit's learning rate", kind="number", min=0.0, max=1.0, min_exclusive=True)
    refit_decay: bool = setting(False, "the refit's learning rate decays with the run", kind="bool")
    dagger_every: int = setting(0, "timesteps between DAgger rounds (0: none)", kind="whole", min=0)
    dagger_episodes: int = setting(20, "episodes the student drives per DAgger round", kind="whole", min=0)
    heat_weight: float = setting(0.0, "the fit's extra weight near derating", kind="number", min=0.0, max=1000.0,
                                 what=" (the extra weight of a state near derating)")
    heat_weight_above_x: float = setting(0.0, "where the extra weight starts", kind="number", min=-0.3, max=1.0,
                                         what=" (a heat-index integrator value)")
    cost_weight: float = setting(0.0, "the weight of the teacher's cost of the student's action", kind="number",
                                 min=0.0, max=1000.0,
                                 what=" (1/g: the weight of the teacher's cost of the student's action)")

    def validate(self) -> None:
        f = self.freeze_obs_stats
        if not isinstance(f, bool) and not (isinstance(f, list) and f and all(isinstance(n, str) for n in f)):
            raise ValueError(f"init.freeze_obs_stats must be true, false or a list of observation names, got {f!r}")
        if self.imitate is None and f is not False:
            raise ValueError("init.freeze_obs_stats keeps the statistics of an imitation start; set init.imitate "
                             "or leave it false")
        if self.teacher_options is None:
            object.__setattr__(self, "teacher_options", {})
        if not isinstance(self.teacher_options, dict):
            raise ValueError(f"init.teacher_options must be a mapping of {self.imitate}'s options (or null), got "
                             f"{self.teacher_options!r}")
        if self.dagger_every and not self.refit_batches:
            raise ValueError("init.dagger_every adds the student's states to the refitted demonstrations; set "
                             "init.refit_batches > 0 or leave it 0")

    def for_run(self, algo: str, names: tuple[str, ...] | list[str] = ()) -> InitConfig:
        """This section, checked against the run: an imitation start needs a PPO algorithm and a teacher that can be
        built with its options (and prices its actions for ``cost_weight``); ``freeze_obs_stats`` may list the
        env's observation ``names`` only."""
        f = self.freeze_obs_stats
        unknown = [n for n in f if n not in names] if isinstance(f, list) and names else []
        if unknown:
            raise ValueError(f"init.freeze_obs_stats: unknown observation(s) {unknown}; observations: "
                             f"{', '.join(names)}")
        teacher = self.imitate
        if teacher is None:
            return self
        if algo not in IMITATING_ALGORITHMS:
            raise ValueError(f"init.imitate={teacher!r}: imitation starts PPO runs only "
                             f"({', '.join(IMITATING_ALGORITHMS)}; algo {algo}); set it to null")
        teachers = [cls.name for cls in registered() if cls.teacher]
        if not isinstance(teacher, str) or teacher not in teachers:
            raise ValueError(f"init.imitate={teacher!r}: the teacher must be a step-by-step classic strategy, one of "
                             f"{', '.join(teachers)}")
        try:
            strategy = teacher_of(self.to_dict())
        except ValueError as e:
            raise ValueError(f"init.teacher_options: {e} (another teacher: set init.teacher_options=null for its "
                             "defaults)") from None
        if self.cost_weight and not hasattr(strategy, "cost_curve_g"):
            raise _unpriced(strategy)
        return self


#: The ``init`` section's keys and defaults.
INIT_DEFAULTS: dict[str, Any] = InitConfig().to_dict()


def _unpriced(teacher: Strategy) -> ValueError:
    return ValueError(f"init.cost_weight: the teacher {teacher.name!r} does not price its candidate actions; use "
                      "ecms, aecms or ecms_thermal, or set init.cost_weight to 0")


class FrozenRunningMeanStd(RunningMeanStd):
    """Observation statistics of which the entries ``frozen`` (a boolean mask) no longer move
    (``init.freeze_obs_stats``); the others are updated as usual."""

    def __init__(self, rms: RunningMeanStd, frozen: np.ndarray):
        super().__init__(shape=rms.mean.shape)
        self.mean, self.var, self.count = rms.mean.copy(), rms.var.copy(), rms.count
        self.frozen = np.asarray(frozen, dtype=bool)
        self._mean0, self._var0 = self.mean[self.frozen].copy(), self.var[self.frozen].copy()

    def update(self, arr: np.ndarray) -> None:
        if self.frozen.all():
            return
        super().update(arr)
        self.mean[self.frozen], self.var[self.frozen] = self._mean0, self._var0


def teacher_of(init: dict[str, Any]) -> Strategy:
    """The teacher ``init`` names (``init.imitate``), built with its options (``init.teacher_options``)."""
    return get_strategy(init["imitate"], **(init.get("teacher_options") or {}))


def demonstrations(env_kwargs: dict[str, Any], teacher: str | Strategy, episodes: int, seed: int,
                   progress: Callable[[int], None] | None = None, noise: float = 0.0,
                   drive: Callable[[np.ndarray], np.ndarray] | None = None, costs: list | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Observations [N, dim] (float32) and the teacher's actions [N] on ``episodes`` episodes of the env, episode
    ``i`` reset with seed ``seed · 1,000,003 + i`` and driven from its first second; ``teacher``: a strategy's name
    (its defaults) or a strategy (:func:`teacher_of`). With a list ``costs``, each step's cost curve of the teacher
    (its ``cost_curve_g``, float32, :mod:`.fit`) is appended to it.

    With ``noise`` > 0 the env is driven by the teacher's action plus a normal draw of that spread (drawn from
    ``seed``): the demonstrations visit the states a policy that explores (PPO: ``log_std_init`` −1, a spread of 0.37)
    or errs reaches, and show the teacher's way back. With ``drive`` (raw observation → action) another policy drives
    and the teacher only labels (DAgger).
    """
    env = HevThermalEnv(**{**env_kwargs, "random_start": False})
    strategy = get_strategy(teacher) if isinstance(teacher, str) else teacher
    rng = np.random.default_rng([int(seed), 7])
    obs_rows: list[np.ndarray] = []
    actions: list[float] = []
    try:
        for i in range(episodes):
            obs, info = env.reset(seed=int(seed) * 1_000_003 + i)
            strategy.reset(env)
            done = False
            while not done:
                a = np.asarray(strategy.act(obs, info), dtype=np.float64).reshape(1)
                obs_rows.append(np.array(obs, dtype=np.float32))
                if costs is not None:
                    if getattr(strategy, "cost_curve_g", None) is None:
                        raise _unpriced(strategy)
                    costs.append(np.asarray(strategy.cost_curve_g, dtype=np.float32))
                actions.append(float(a[0]))
                if drive is not None:
                    a = np.asarray(drive(obs), dtype=np.float64).reshape(1)
                elif noise > 0.0:
                    a = a + noise * rng.standard_normal(1)
                obs, _, terminated, truncated, info = env.step(a)
                done = terminated or truncated
            if progress is not None:
                progress(1)
    finally:
        env.close()
    return np.stack(obs_rows), np.asarray(actions, dtype=np.float32)


def heat_weighting(init: dict[str, Any]) -> tuple[float, float]:
    """``init.heat_weight`` and ``init.heat_weight_above_x`` (their defaults where the section has none)."""
    return (float(init.get("heat_weight", INIT_DEFAULTS["heat_weight"])),
            float(init.get("heat_weight_above_x", INIT_DEFAULTS["heat_weight_above_x"])))


class DemonstrationRefit(BaseCallback):
    """``init.refit_batches`` > 0: after every rollout, that many batches of the demonstrations are fitted again (by
    the imitation's loss, :mod:`.fit`; Adam at ``init.refit_lr``, decaying with PPO's schedule with
    ``init.refit_decay``), normalised with the statistics of that moment, so the fit follows them as they drift. With
    ``init.dagger_every`` (env-steps) the deterministic policy drives ``init.dagger_episodes`` fresh training episodes
    that often, and the teacher's actions on the states it visits join the demonstrations (DAgger)."""

    def __init__(self, obs: np.ndarray, actions: np.ndarray, curves: np.ndarray | None = None, *,
                 init: dict[str, Any], env_kwargs: dict, high: float, seed: int):
        super().__init__()
        self.high, self.env_kwargs, self.curves = float(high), env_kwargs, curves
        self.batches, self.lr = int(init["refit_batches"]), float(init["refit_lr"])
        self.decay = bool(init["refit_decay"])
        self.beyond_bound, self.cost_weight = float(init["beyond_bound"]), float(init["cost_weight"])
        self.teacher, self.heat_weight = teacher_of(init), heat_weighting(init)
        self.dagger_every, self.dagger_episodes = int(init["dagger_every"]), int(init["dagger_episodes"])
        self.seed, self.rounds = int(seed), 0
        self.rng = np.random.default_rng([int(seed), 11])
        self.opt: torch.optim.Optimizer | None = None
        self.mse: list[float] = []
        self._set_demonstrations(obs, actions)

    def _set_demonstrations(self, obs: np.ndarray, actions: np.ndarray) -> None:
        self.obs, self.actions = obs, actions
        self.target = fit_targets(actions, self.high, self.beyond_bound)
        self.weight = fit_weights(obs, *self.heat_weight)

    def _init_callback(self) -> None:
        # the live model and statistics, normalised and acting as every policy does (the student of DAgger)
        self.policy = LoadedPolicy(self.model, self.model.get_vec_normalize_env())

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        if self.dagger_every and self.model.num_timesteps >= self.dagger_every * (self.rounds + 1):
            self.rounds += 1
            costs = [] if self.curves is not None else None
            obs, actions = demonstrations(self.env_kwargs, self.teacher, self.dagger_episodes,
                                          self.seed + 1_000 * self.rounds,
                                          drive=lambda o: self.policy.act(np.asarray(o)[None])[0], costs=costs)
            if costs is not None:
                self.curves = np.concatenate([self.curves, np.stack(costs)])
            self._set_demonstrations(np.concatenate([self.obs, obs]), np.concatenate([self.actions, actions]))
        policy = self.model.policy
        if self.opt is None:
            self.opt = torch.optim.Adam(policy.parameters(), lr=self.lr)
        if self.decay:  # the refit's rate follows PPO's schedule: late in the run neither moves the policy much
            schedule = self.model.lr_schedule
            for group in self.opt.param_groups:
                group["lr"] = self.lr * schedule(self.model._current_progress_remaining) / schedule(1.0)
        total = 0.0
        for _ in range(self.batches):
            idx = self.rng.integers(0, len(self.obs), BATCH)
            x = torch.as_tensor(np.asarray(self.policy.normalize(self.obs[idx]), dtype=np.float32))
            total += adam_step(self.opt, batch_loss(policy, x, self.target, idx, self.weight, self.curves,
                                                    self.cost_weight))
        self.mse.append(total / max(self.batches, 1))

    def summary(self) -> dict[str, Any]:
        """What the run records (``result.imitation.refit``)."""
        return {"batches_per_rollout": self.batches, "lr": self.lr, "refits": len(self.mse),
                "mse_last": round(self.mse[-1], 5) if self.mse else None, "dagger_rounds": self.rounds,
                "demonstration_steps": int(len(self.actions))}


def _demonstrations(env_kwargs: dict[str, Any], init: dict[str, Any], seed: int,
                    progress: Callable[[int], None] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The run's first demonstrations (``init.episodes`` of the teacher, ``init.noise``) and, with
    ``init.cost_weight`` > 0, the teacher's cost curves [N, n] (else None)."""
    costs = [] if init["cost_weight"] > 0.0 else None
    obs, actions = demonstrations(env_kwargs, teacher_of(init), init["episodes"], seed, progress,
                                  noise=float(init["noise"]), costs=costs)
    return obs, actions, None if costs is None else np.stack(costs)


def resumed_refit(model: Any, env_kwargs: dict[str, Any], init: dict[str, Any],
                  seed: int) -> DemonstrationRefit | None:
    """The refit of a resumed run (None without ``init.imitate`` and ``init.refit_batches``): its first
    demonstrations driven again (the same episodes and actions), DAgger continuing from the next round; the student's
    states of earlier rounds and the refit's optimiser state are not kept in a checkpoint."""
    if not init.get("imitate") or init["refit_batches"] <= 0:
        return None
    refit = DemonstrationRefit(*_demonstrations(env_kwargs, init, seed), init=init, env_kwargs=env_kwargs,
                               high=float(model.action_space.high[0]), seed=seed)
    if refit.dagger_every:
        refit.rounds = int(model.num_timesteps) // refit.dagger_every
    return refit


def imitate(model: Any, env_kwargs: dict[str, Any], init: dict[str, Any], seed: int, *,
            progress: bool = True) -> tuple[dict[str, Any], DemonstrationRefit | None]:
    """Start ``model`` (PPO) and its ``VecNormalize`` statistics from the teacher's behaviour (module docstring);
    returns what to record in the config and the :class:`DemonstrationRefit` to run during PPO (None without
    ``init.refit_batches``)."""
    t0 = time.perf_counter()
    with tqdm(total=init["episodes"], desc=f"imitating {init['imitate']}", unit="episode", disable=not progress) as bar:
        obs, actions, curves = _demonstrations(env_kwargs, init, seed, bar.update)
    demo_s = time.perf_counter() - t0
    x, venv = obs, model.get_vec_normalize_env()
    if venv is not None and venv.norm_obs:
        venv.obs_rms.mean = obs.mean(axis=0, dtype=np.float64)
        venv.obs_rms.var = obs.var(axis=0, dtype=np.float64)
        venv.obs_rms.count = float(len(obs))
        freeze = init["freeze_obs_stats"]  # every entry the demonstrations vary, or those named
        if freeze is not False:
            names = observation_names(int(env_kwargs["preview_s"]), int(env_kwargs["preview_step_s"]))
            mask = venv.obs_rms.var > MIN_FROZEN_VAR if freeze is True else np.isin(np.asarray(names), freeze)
            venv.obs_rms = FrozenRunningMeanStd(venv.obs_rms, mask)
        x = venv.normalize_obs(obs)
    high = float(model.action_space.high[0])
    heat_weight, above_x = heat_weighting(init)
    history = fit_policy_mean(model.policy, x, actions, epochs=init["epochs"],
                              beyond_bound=float(init["beyond_bound"]), high=high, seed=seed,
                              weights=fit_weights(obs, heat_weight, above_x), curves=curves,
                              cost_weight=float(init["cost_weight"]))
    refit = None
    if init["refit_batches"] > 0:
        refit = DemonstrationRefit(obs, actions, curves, init=init, env_kwargs=env_kwargs, high=high, seed=seed)
    return {"teacher": init["imitate"], "teacher_options": dict(init["teacher_options"]),
            "episodes": init["episodes"], "noise": float(init["noise"]), "steps": int(len(actions)),
            "near_derating_share": round(float(np.mean(near_derating(obs, above_x))), 4),
            "teacher_at_bound": round(float(np.mean(actions >= high)), 4),
            "mse_first": round(history[0], 5) if history else None,
            "mse_last": round(history[-1], 5) if history else None,
            "cost_excess_g_per_step": None if curves is None else round(mean_cost_excess_g(model.policy, x, curves), 5),
            "demonstration_s": round(demo_s, 1), "wall_s": round(time.perf_counter() - t0, 1)}, refit
