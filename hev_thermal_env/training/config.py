"""The config of a training run: one plain dict, saved as ``DIR/config.yaml``.

:func:`build_config` makes it from the hyperparameter file (:mod:`.hyperparams`), the ``--hp`` overrides and the
command-line settings; :func:`validate_config` checks all of it before anything is created (one-line ``ValueError``
s). Sections: ``algo``, ``seed``, ``total_timesteps``, ``n_envs``, ``env`` (the training env), ``normalize``
(``VecNormalize``), ``init`` (:mod:`.imitation`), ``constraint`` (a constrained algorithm's safety-cost budget and
multiplier, :mod:`.lagrangian`; None for the others), ``hyperparams`` (the SB3 constructor's), ``eval``,
``checkpoint_freq``, ``task`` (the id of the benchmark task the run trains for, or None), ``command``, ``created``,
``versions``, and after training ``result``. No run trains or selects checkpoints on a held-out task's test cycles.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import inspect
import platform
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import gymnasium
import numpy as np
import stable_baselines3
import torch
from stable_baselines3.common.vec_env import VecNormalize

import hev_thermal_env
from hev_thermal_env.cycles import expand_cycle_names, load_cycle
from hev_thermal_env.cycles.names import is_family
from hev_thermal_env.envs.episodes import check_soc_offset
from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.envs.spaces import observation_names
from hev_thermal_env.io import atomic_write_yaml, read_yaml_mapping
from hev_thermal_env.physics.fingerprint import physics_fingerprint
from hev_thermal_env.scenarios import get_scenario
from hev_thermal_env.tasks import TRAINING_FAMILIES, get_task, held_out_cycles

from .hyperparams import Section, apply_overrides, check_hyperparams, check_known, load_hyperparams, setting
from .imitation import InitConfig
from .lagrangian import ConstraintConfig
from .selection import DEFAULT_SCORER, get_scorer

#: ``VecNormalize`` arguments of the ``normalize`` section (its ``gamma`` is the algorithm's), and their defaults.
NORMALIZE_KEYS = tuple(k for k in inspect.signature(VecNormalize.__init__).parameters
                       if k not in ("self", "venv", "gamma"))
NORMALIZE_DEFAULTS = {"norm_obs": True, "norm_reward": True, "clip_obs": 10.0, "clip_reward": 10.0}


@dataclasses.dataclass(frozen=True)
class RunSettings(Section):
    """The run's top-level numbers."""

    NAME: ClassVar[str] = ""

    seed: int = setting(0, "the run's seed (--seed)", kind="whole", min=0, max=2**32 - 1)
    total_timesteps: int = setting(1_000_000, "timesteps to train (n_timesteps in a file)", kind="whole", min=1)
    n_envs: int = setting(1, "training envs stepped together", kind="whole", min=1)
    checkpoint_freq: int = setting(500_000, "timesteps between checkpoints", kind="whole", min=1)


RUN_DEFAULTS = RunSettings()


@dataclasses.dataclass(frozen=True)
class EnvConfig(Section):
    """The ``env`` section: the environment a run trains on (by default every family of generated bus cycles, random
    service conditions, random starts, a 10 s preview); the check fills ``observation_size`` and
    ``observation_names``, what a trained policy expects."""

    NAME: ClassVar[str] = "env"

    cycles: list[str] | str = setting(list(TRAINING_FAMILIES), "training cycles: names, families, sets or CSV paths")
    scenario: str = setting("random_service", "the training scenario")
    random_start: bool = setting(True, "episodes start anywhere in the cycle")
    preview_s: int = setting(10, "seconds of the cycle ahead in the observation")
    preview_step_s: int = setting(2, "the preview's step")
    thermal: bool = setting(True, "the motor's thermal model on")
    reward: dict[str, Any] | None = setting({}, "RewardParams fields set otherwise")
    soc_offset: float = setting(0.0, "the SOC target's offset")
    observation_size: int | None = setting(None, "filled by the check")
    observation_names: list[str] | None = setting(None, "filled by the check")

    def validate(self) -> None:
        cycles = self.cycles if isinstance(self.cycles, list) else [self.cycles]
        if not cycles:
            raise ValueError("no training cycles given")
        for c in expand_cycle_names(cycles):
            if not is_family(c):
                _refuse_held_out("env.cycles", c)
                load_cycle(c)
        get_scenario(self.scenario)
        RewardParams.from_dict(dict(self.reward or {}), where="env.reward")
        check_soc_offset(self.soc_offset, "env.soc_offset")
        names = observation_names(whole_number("env.preview_s", self.preview_s),
                                  whole_number("env.preview_step_s", self.preview_step_s))
        for key, value in (("cycles", [str(c) for c in cycles]), ("observation_size", len(names)),
                           ("observation_names", list(names))):
            object.__setattr__(self, key, value)


@dataclasses.dataclass(frozen=True)
class EvalConfig(Section):
    """The ``eval`` section: the periodic evaluation. The checkpoints are scored on the last ten validation cycles
    (one of each rotating family, then five express routes); ``validation_bus:0..19`` are left for judging the
    trained policies."""

    NAME: ClassVar[str] = "eval"

    cycles: list[str] | None = setting(["validation_bus:20..29"], "the checkpoints' evaluation cycles")
    scenarios: list[str] = setting(["paper", "full_bus"], "the evaluation scenarios (fixed conditions)")
    freq: int = setting(100_000, "env-steps between evaluations (0: none)")
    selection: str = setting(DEFAULT_SCORER, "the rule that picks best_model.zip (training.selection)")
    final_cycles: list[str] | None = setting(["validation_bus"], "the best and final models' validation cycles")

    def validate(self) -> None:
        if whole_number("eval.freq", self.freq) < 0:
            raise ValueError(f"eval.freq must be at least 0, got {self.freq}")
        scorer = get_scorer(str(self.selection))
        for s in self.scenarios:
            if get_scenario(s).randomized and self.cycles:
                raise ValueError(f"eval.selection {scorer.name} compares with a reference on the same conditions: "
                                 f"the evaluation scenarios must be fixed, and {s!r} draws them at random")
        for key in ("cycles", "final_cycles"):
            object.__setattr__(self, key, [str(c) for c in (getattr(self, key) or [])])

    def for_run(self, env: EnvConfig) -> EvalConfig:
        """This section with its cycles checked: each loaded, none a held-out task's test cycle or a training one."""
        trained = {str(c).strip().lower() for c in expand_cycle_names(env.cycles) if not is_family(c)}
        for key in ("cycles", "final_cycles"):
            for c in expand_cycle_names(getattr(self, key)):
                _refuse_held_out(f"eval.{key}", c)
                if str(c).strip().lower() in trained:
                    raise ValueError(f"eval.{key}: {c!r} is also a training cycle; a run must be scored on cycles "
                                     "it does not train on")
                load_cycle(c)
        return self


#: The ``env`` and ``eval`` sections' settings and defaults.
ENV_DEFAULTS = {f.name: f.default_factory() if callable(f.default_factory) else f.default
                for f in dataclasses.fields(EnvConfig) if not f.name.startswith("observation_")}
EVAL_DEFAULTS = {f.name: f.default_factory() if callable(f.default_factory) else f.default
                 for f in dataclasses.fields(EvalConfig)}


def whole_number(key: str, value: Any) -> int:
    """``int(value)``, or a one-line ValueError naming ``key`` and ``value``."""
    try:
        return int(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key}={value!r}: expected a whole number") from None


def build_config(algo: str, *, hyperparams_file: str | Path | None = None, overrides: dict[str, Any] | None = None,
                 cycles: Sequence[str] | None = None, scenario: str | None = None, timesteps: int | None = None,
                 n_envs: int | None = None, seed: int = 0, eval_cycles: Sequence[str] | None = None,
                 eval_scenarios: Sequence[str] | None = None, eval_freq: int | None = None,
                 checkpoint_freq: int | None = None, command: str | None = None, task: str | None = None
                 ) -> dict[str, Any]:
    """The complete config of a run (validated): the hyperparameter file, the ``overrides`` (``--hp``), the
    settings given here (None: not given), then the defaults of what none of them sets. ``task``: a benchmark task
    (:func:`~hev_thermal_env.tasks.get_task`) whose training cycles and scenario the run trains on, instead of
    ``cycles`` and ``scenario``."""
    algo = str(algo).lower()
    task_id = None
    if task is not None:
        if cycles is not None or scenario is not None:
            raise ValueError(f"--task {task} sets the training cycles and scenario; drop --cycles and --scenario")
        clash = sorted(k for k in (overrides or {}) if k in ("env", "env.cycles", "env.scenario"))
        if clash:
            raise ValueError(f"--task {task} sets the training cycles and scenario; drop --hp {', '.join(clash)}")
        resolved = get_task(task)
        task_id, (cycles, scenario) = resolved.id, resolved.training
    given = {"env.cycles": cycles, "env.scenario": scenario, "n_timesteps": timesteps, "n_envs": n_envs,
             "eval.cycles": eval_cycles, "eval.scenarios": eval_scenarios, "eval.freq": eval_freq,
             "checkpoint_freq": checkpoint_freq}
    given = {k: list(v) if isinstance(v, (list, tuple)) else v for k, v in given.items() if v is not None}
    hp = apply_overrides(load_hyperparams(algo, hyperparams_file), {**(overrides or {}), **given})
    env, ev = hp.pop("env", None), hp.pop("eval", None)
    normalize = hp.pop("normalize", None)
    if normalize is not False:
        if not isinstance(normalize, (dict, bool, type(None))):
            raise ValueError(f"normalize={normalize!r}: expected true, false or a mapping")
        normalize = {**NORMALIZE_DEFAULTS, **(normalize if isinstance(normalize, dict) else {})}
    init = dict(hp.pop("init", None) or {})
    constraint = hp.pop("constraint", None)
    total = whole_number("n_timesteps", hp.pop("n_timesteps", RUN_DEFAULTS.total_timesteps))
    envs = whole_number("n_envs", hp.pop("n_envs", RUN_DEFAULTS.n_envs))
    ckpt = whole_number("checkpoint_freq", hp.pop("checkpoint_freq", RUN_DEFAULTS.checkpoint_freq))
    hp.setdefault("policy", "MlpPolicy")
    config = {"algo": algo, "seed": whole_number("seed", seed), "total_timesteps": total, "n_envs": envs, "env": env,
              "normalize": normalize, "init": init, "constraint": constraint, "hyperparams": hp, "eval": ev,
              "checkpoint_freq": ckpt, "task": task_id, "command": command,
              "created": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
              "versions": {"python": platform.python_version(), "numpy": str(np.__version__),
                           "torch": str(torch.__version__), "stable_baselines3": str(stable_baselines3.__version__),
                           "gymnasium": str(gymnasium.__version__), "hev_thermal_env": hev_thermal_env.__version__,
                           "platform": platform.platform(), "physics_fingerprint": physics_fingerprint()}}
    validate_config(config)
    return config


def validate_config(config: dict[str, Any]) -> None:
    """Fail before any work, with one-line messages, on unknown names, wrong types and impossible numbers.

    Fills ``env.observation_size`` and ``env.observation_names`` (what a trained policy expects)."""
    env = EnvConfig.from_dict(config["env"])
    config["env"], config["eval"] = env.to_dict(), EvalConfig.from_dict(config["eval"]).for_run(env).to_dict()
    init = InitConfig.from_dict(config.get("init")).for_run(config["algo"], config["env"]["observation_names"])
    config["init"] = init.to_dict()
    constraint = ConstraintConfig.of_run(config.get("constraint"), config["algo"], config.get("task"))
    config["constraint"] = None if constraint is None else constraint.to_dict()
    if config["normalize"] is not False:
        check_known("normalize setting", config["normalize"], NORMALIZE_KEYS)
    RunSettings(**{f.name: config[f.name] for f in dataclasses.fields(RunSettings)})
    check_hyperparams(config["algo"], config["hyperparams"])
    hp, n_envs = config["hyperparams"], config["n_envs"]  # the sizes SB3 asserts on, as one-line errors
    on_policy = config["algo"] in ("ppo", "ppo_lagrangian", "recurrent_ppo")  # PPO's rollouts: n_steps per env
    if on_policy and "n_steps" in hp and whole_number("n_steps", hp["n_steps"]) * n_envs < 2:
        raise ValueError(f"n_steps={hp['n_steps']} with n_envs={n_envs}: PPO needs n_steps × n_envs of at least 2")
    least = 2 if on_policy else 1
    if "batch_size" in hp and whole_number("batch_size", hp["batch_size"]) < least:
        raise ValueError(f"batch_size must be at least {least}, got {hp['batch_size']}")


def _refuse_held_out(key: str, cycle: Any) -> None:
    """A one-line ValueError if ``cycle`` is a test cycle of a held-out benchmark task."""
    task = held_out_cycles().get(str(cycle).strip().lower())
    if task is not None:
        raise ValueError(f"{key}: {cycle!r} is a test cycle of the benchmark task {task}; a run neither trains nor "
                         f"selects checkpoints on a held-out test set")


def save_run_config(run_dir: str | Path, config: dict[str, Any]) -> Path:
    """Write ``DIR/config.yaml`` atomically."""
    return atomic_write_yaml(Path(run_dir) / "config.yaml", config)


def load_run_config(run_dir: str | Path) -> dict[str, Any]:
    """The config of the run in ``run_dir`` (one-line errors when it is not a run directory)."""
    p = Path(run_dir) / "config.yaml"
    if not Path(run_dir).is_dir():
        raise FileNotFoundError(f"run directory {run_dir} not found")
    if not p.is_file():
        raise FileNotFoundError(f"{p} not found: {run_dir} is not a train.py run directory")
    data = read_yaml_mapping(p)
    if "algo" not in data or "env" not in data:
        raise ValueError(f"{p}: not a train.py config")
    return data
