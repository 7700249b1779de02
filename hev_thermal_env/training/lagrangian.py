"""PPO-Lagrangian (``train.py --algo ppo_lagrangian``): PPO on the reward less λ times the safety cost, λ learned.

:class:`LagrangianVecEnv`, under ``VecNormalize``, hands PPO ``reward − λ · info["cost"]`` (the safety cost in seconds
of lost motor capability per step, λ in grams of fuel per second). After every rollout λ takes one step of dual
ascent (:func:`dual_ascent`) on "episode safety cost per hour driven ≤ budget": ``λ ← clip(λ + lr · (J − d), 0,
λ_max)``, J the cost per hour of the episodes that ended since the last update (none: no update), d
``constraint.budget_s_per_h``. docs/training.md.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

from hev_thermal_env.io import atomic_write_text

from .hyperparams import Section, setting


@dataclasses.dataclass(frozen=True)
class ConstraintConfig(Section):
    """The ``constraint`` section (numbers, stored as floats); :meth:`of_run` builds it for a run."""

    NAME: ClassVar[str] = "constraint"

    budget_s_per_h: float = setting(36.0, "the allowed episode safety cost per hour driven (36 s/h: one per cent of "
                                    "the time with the motor fully derated), or 'task' for the budget stored with "
                                    "the training task's references (task_budget_s_per_h)", kind="number", min=0.0)
    lambda_init: float = setting(0.0, "λ's start (g of fuel per second of safety cost)", kind="number", min=0.0)
    lambda_lr: float = setting(0.005, "λ's step per update, in g/s of λ per s/h of excess", kind="number", min=0.0)
    lambda_max: float = setting(50.0, "λ's ceiling (g of fuel per second of safety cost)", kind="number", min=0.0)

    def validate(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, float(getattr(self, f.name)))
        if self.lambda_init > self.lambda_max:
            raise ValueError(f"constraint.lambda_init={self.lambda_init} is above lambda_max={self.lambda_max}")

    @classmethod
    def of_run(cls, section: Any, algo: str, task_id: str | None) -> ConstraintConfig | None:
        """The section of a run of ``algo`` (None for an unconstrained algorithm, which must not have one); a budget
        of ``task`` is the training task's (``task_id``)."""
        if algo not in CONSTRAINED_ALGORITHMS:
            if section:
                raise ValueError(f"constraint: algorithm {algo} is unconstrained; the constraint section belongs to "
                                 f"{', '.join(CONSTRAINED_ALGORITHMS)}")
            return None
        if isinstance(section, dict) and section.get("budget_s_per_h") == "task":
            budget = task_budget_s_per_h(task_id)
            if budget is None:
                raise ValueError(f"constraint.budget_s_per_h=task: no current safety budget is stored for task "
                                 f"{task_id} (train with --task, and see python evaluate.py reference --check); give "
                                 "the budget in seconds of safety cost per hour driven")
            section = {**section, "budget_s_per_h": budget}
        return cls.from_dict(section)


#: The algorithms that take a ``constraint`` section.
CONSTRAINED_ALGORITHMS = ("ppo_lagrangian",)


def dual_ascent(lam: float, cost_s_per_h: float, budget_s_per_h: float, lr: float, lam_max: float) -> float:
    """One step of dual ascent on λ: ``clip(λ + lr · (cost − budget), 0, lam_max)``."""
    return float(min(lam_max, max(0.0, lam + lr * (cost_s_per_h - budget_s_per_h))))


def task_budget_s_per_h(task_id: str | None) -> float | None:
    """The safety budget of the task ``task_id`` as a rate: its episode budget (stored with the task's references,
    :mod:`hev_thermal_env.evaluation.references`) over the mean length of its episodes in hours; None without a task
    or without a current stored reference (the caller's error says which)."""
    if task_id is None:
        return None
    from hev_thermal_env.cycles import load_cycle
    from hev_thermal_env.evaluation.references import StaleReferenceError, load_reference

    try:
        ref = load_reference(task_id)
    except (FileNotFoundError, StaleReferenceError):
        return None
    hours = [load_cycle(e["cycle"]).n_steps / 3600.0 for e in ref["episodes"]]
    return float(ref["safety_budget_s"]) / float(np.mean(hours))


class LagrangeMultiplier:
    """λ, the episodes that ended since its last update, and its history (rows of :data:`HISTORY_COLUMNS`)."""

    HISTORY_COLUMNS = ("timesteps", "lambda", "cost_s_per_h", "budget_s_per_h", "episodes")

    def __init__(self, budget_s_per_h: float, lambda_lr: float, lambda_init: float = 0.0, lambda_max: float = 50.0):
        self.budget_s_per_h, self.lr, self.lam = float(budget_s_per_h), float(lambda_lr), float(lambda_init)
        self.lam_max = float(lambda_max)
        self.cost_s, self.hours, self.episodes = 0.0, 0.0, 0
        self.history: list[dict[str, float]] = []

    def record_episode(self, cost_s: float, duration_s: float) -> None:
        """An episode ended with safety cost ``cost_s`` after ``duration_s`` seconds driven."""
        self.cost_s += float(cost_s)
        self.hours += float(duration_s) / 3600.0
        self.episodes += 1

    def update(self, timesteps: int) -> float | None:
        """One dual-ascent step on the episodes recorded since the last one; returns their cost per hour (None: no
        episode ended, λ unchanged)."""
        if self.episodes == 0 or self.hours <= 0.0:
            return None
        rate = self.cost_s / self.hours
        self.lam = dual_ascent(self.lam, rate, self.budget_s_per_h, self.lr, self.lam_max)
        self.history.append({"timesteps": int(timesteps), "lambda": round(self.lam, 6),
                             "cost_s_per_h": round(rate, 4), "budget_s_per_h": self.budget_s_per_h,
                             "episodes": self.episodes})
        self.cost_s, self.hours, self.episodes = 0.0, 0.0, 0
        return rate


class LagrangianVecEnv(VecEnvWrapper):
    """Rewards ``reward − λ · info["cost"]`` for PPO (module docstring); the wrapped env must copy ``cost`` into its
    infos. ``update_every``: ``step`` calls between two updates of λ (PPO's ``n_steps``: once per rollout);
    ``dt_s``: the env's step length (episode hours from step counts)."""

    def __init__(self, venv, multiplier: LagrangeMultiplier, update_every: int, dt_s: float):
        super().__init__(venv)
        self.multiplier, self.update_every, self.dt_s = multiplier, int(update_every), float(dt_s)
        self.calls = self.timesteps = 0
        self.episode_cost = np.zeros(self.num_envs)
        self.episode_steps = np.zeros(self.num_envs, dtype=np.int64)

    def reset(self):
        self.episode_cost[:] = 0.0
        self.episode_steps[:] = 0
        return self.venv.reset()

    def step_wait(self):
        obs, reward, dones, infos = self.venv.step_wait()
        cost = np.fromiter((info["cost"] for info in infos), dtype=np.float64, count=self.num_envs)
        shaped = (reward - self.multiplier.lam * cost).astype(np.float32)
        self.episode_cost += cost
        self.episode_steps += 1
        for i in np.flatnonzero(dones):
            self.multiplier.record_episode(self.episode_cost[i], self.episode_steps[i] * self.dt_s)
            self.episode_cost[i], self.episode_steps[i] = 0.0, 0
        self.calls += 1
        self.timesteps += self.num_envs
        if self.calls % self.update_every == 0:
            self.multiplier.update(self.timesteps)
        return obs, shaped, dones, infos


def state_path(model_path: Path) -> Path:
    """Where the multiplier (λ and its history) is saved beside a checkpoint or model zip (``NAME_lagrangian.json``)."""
    return Path(model_path).with_name(Path(model_path).stem + "_lagrangian.json")


def save_multiplier(multiplier: LagrangeMultiplier, model_path: Path) -> None:
    atomic_write_text(state_path(model_path), json.dumps({"lambda": multiplier.lam, "history": multiplier.history}))


def load_multiplier(multiplier: LagrangeMultiplier, model_path: Path) -> None:
    """Restore λ saved beside ``model_path``, if any."""
    if (p := state_path(model_path)).is_file():
        state = json.loads(p.read_text())
        multiplier.lam, multiplier.history = float(state["lambda"]), list(state.get("history") or [])
