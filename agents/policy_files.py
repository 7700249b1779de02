"""The files of a trained policy (written by :mod:`hev_thermal_env.training.artifacts`): where they are, reading them.

:func:`load_policy` loads a :class:`LoadedPolicy` from a run directory (its final ``model.zip``; else
``best_model.zip``; else the latest checkpoint) or a model zip. The observation statistics lie next to the zip:
``model.zip`` → ``vecnormalize.pkl``, ``best_model.zip`` → ``best_vecnormalize.pkl``, ``checkpoints/ckpt_N_steps.zip`` →
``ckpt_N_steps_vecnormalize.pkl``, any other ``NAME.zip`` → ``NAME_vecnormalize.pkl`` or ``vecnormalize.pkl``. The run's
``config.yaml`` (beside the zip, or above ``checkpoints/``) gives the algorithm (:data:`ALGORITHMS`) and the observation
layout. A missing file raises ``FileNotFoundError``, an unreadable one ``ValueError``, each in one line. A model zip
pickles its schedules by the import path of :class:`LinearSchedule`; loading rebuilds them from the run's
hyperparameters instead (:func:`custom_objects`).
"""

from __future__ import annotations

import importlib
import logging
import pickle
import re
import warnings
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hev_thermal_env.physics.fingerprint import physics_fingerprint

#: The algorithms ``train.py`` trains, by name (``ppo_lagrangian``, :mod:`hev_thermal_env.training.lagrangian`, makes a
#: PPO model).
ALGORITHMS = {"ppo": "stable_baselines3:PPO", "sac": "stable_baselines3:SAC", "tqc": "sb3_contrib:TQC",
              "recurrent_ppo": "sb3_contrib:RecurrentPPO", "ppo_lagrangian": "stable_baselines3:PPO"}
#: The off-policy algorithms (a replay buffer, checkpointed with the model).
OFF_POLICY = ("sac", "tqc")
CHECKPOINTS = "checkpoints"
_CKPT_RE = re.compile(r"^ckpt_(\d+)_steps\.zip$")


def algorithm_class(algo: str):
    """The SB3 class of ``algo`` (a key of :data:`ALGORITHMS`)."""
    name = str(algo).lower()
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}; known algorithms: {', '.join(ALGORITHMS)}")
    module, cls = ALGORITHMS[name].split(":")
    try:
        return getattr(importlib.import_module(module), cls)
    except ImportError:
        raise ImportError(f"algorithm {name} needs the package {module.replace('_', '-')} "
                          f"(pip install {module.replace('_', '-')})") from None


#: Hyperparameters that may be schedules.
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")


class LinearSchedule:
    """``progress_remaining`` (1 -> 0) times the initial value; picklable (saved inside the model)."""

    def __init__(self, initial: float):
        self.initial = float(initial)

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.initial

    def __repr__(self) -> str:
        return f"lin_{self.initial:g}"


def schedule(value: Any) -> Any:
    """``"lin_3e-4"`` -> a linear decay from 3e-4 to 0 over training; numbers stay constants."""
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            initial = float(value[4:])
        except ValueError:
            raise ValueError(f"schedule {value!r}: expected lin_<number>, e.g. lin_3e-4") from None
        return LinearSchedule(initial)
    return value


def custom_objects(hyperparams: Mapping[str, Any] | None) -> dict[str, Any]:
    """``custom_objects`` for SB3's ``load``: the schedules of a run, rebuilt from its hyperparameters (``lr_schedule``
    only so that the saved one is not unpickled: SB3 recomputes it)."""
    hp = hyperparams or {}
    objects = {key: schedule(hp[key]) for key in SCHEDULE_KEYS if key in hp}
    if "learning_rate" in objects:
        objects["lr_schedule"] = objects["learning_rate"]
    return objects


def checkpoint_paths(run_dir: str | Path, timesteps: int) -> tuple[Path, Path, Path]:
    """(model zip, statistics pickle, SAC replay buffer) of the run's checkpoint at ``timesteps``."""
    stem = Path(run_dir) / CHECKPOINTS / f"ckpt_{int(timesteps)}_steps"
    return stem.with_name(stem.name + ".zip"), Path(f"{stem}_vecnormalize.pkl"), Path(f"{stem}_replay_buffer.pkl")


def checkpoint_files(run_dir: str | Path) -> list[tuple[int, Path, Path]]:
    """Complete checkpoints of a run (their model zip, written last, exists), oldest first: (timesteps, model zip,
    statistics pickle)."""
    found = [(int(m.group(1)), p) for p in (Path(run_dir) / CHECKPOINTS).glob("ckpt_*_steps.zip")
             if (m := _CKPT_RE.match(p.name))]
    return sorted((n, p, checkpoint_paths(run_dir, n)[1]) for n, p in found)


def stats_path_for(model_path: Path) -> Path:
    """Where the observation statistics of ``model_path`` are saved (see the module docstring)."""
    model_path = Path(model_path)
    named = {"model.zip": "vecnormalize.pkl", "best_model.zip": "best_vecnormalize.pkl"}
    if model_path.name in named:
        return model_path.with_name(named[model_path.name])
    own = model_path.with_name(model_path.stem + "_vecnormalize.pkl")
    if own.exists() or _CKPT_RE.match(model_path.name):
        return own
    return model_path.with_name("vecnormalize.pkl")


def resolve_model_path(path: str | Path) -> Path:
    """The model zip that ``path`` (a run directory or a zip) designates."""
    p = Path(path).expanduser()
    if p.is_dir():
        found = [p / n for n in ("model.zip", "best_model.zip") if (p / n).is_file()]
        found += [ckpt for _, ckpt, _ in checkpoint_files(p)[-1:]]  # the latest checkpoint
        if found:
            return found[0]
        raise FileNotFoundError(f"ppo: no model in directory {p} (expected model.zip, best_model.zip or "
                                f"checkpoints/ckpt_N_steps.zip from train.py)")
    if p.is_file():
        return p
    if p.suffix != ".zip" and p.with_suffix(".zip").is_file():
        return p.with_suffix(".zip")
    raise FileNotFoundError(f"ppo: model file {p} not found")


def find_run_config(model_path: Path) -> dict[str, Any] | None:
    """The ``config.yaml`` of the run the model belongs to, or None."""
    here = Path(model_path).parent
    for d in (here, here.parent) if here.name == "checkpoints" else (here,):
        cfg = d / "config.yaml"
        if cfg.is_file():
            try:
                data = yaml.safe_load(cfg.read_text())
            except (yaml.YAMLError, OSError, UnicodeDecodeError) as exc:
                raise ValueError(f"ppo: {cfg} is not a readable config file ({_one_line(exc)})") from None
            if not isinstance(data, dict):
                raise ValueError(f"ppo: {cfg} is not a train.py config (expected a mapping)")
            return data
    return None


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def load_obs_normalizer(path: Path):
    """The pickled ``VecNormalize`` (statistics only, no env) of a run; raises one-line errors."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"ppo: observation statistics {path} not found (train.py saves them next to "
                                f"the model; a model trained without normalisation needs normalize=False)")
    try:
        with open(path, "rb") as fh:
            stats = pickle.load(fh)
    except Exception as exc:  # noqa: BLE001 - any unpickling failure means the file is unusable
        raise ValueError(f"ppo: {path} is not a readable VecNormalize file ({_one_line(exc)})") from None
    if not hasattr(stats, "normalize_obs") or not hasattr(stats, "obs_rms"):
        raise ValueError(f"ppo: {path} holds a {type(stats).__name__}, not VecNormalize statistics")
    return stats


def load_sb3_model(path: Path, algo: str = "ppo", hyperparams: dict[str, Any] | None = None):
    """An SB3 model (any of :data:`ALGORITHMS`) from a zip on the CPU; raises one-line errors.

    ``hyperparams`` (the run's) rebuild the saved schedules (:func:`custom_objects`)."""
    cls = algorithm_class(algo)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return cls.load(path, device="cpu", custom_objects=custom_objects(hyperparams))
    except Exception as exc:  # noqa: BLE001 - zip, pickle and torch errors all mean "unreadable model"
        if isinstance(exc, zipfile.BadZipFile) or not zipfile.is_zipfile(path):
            raise ValueError(f"ppo: {path} is not a model zip ({_one_line(exc)})") from None
        raise ValueError(f"ppo: cannot load {path} as an SB3 {algo.upper()} model ({_one_line(exc)})") from None


class LoadedPolicy:
    """A model and its observation statistics (a ``VecNormalize`` only read, or None): ``act(obs [n, dim]) -> actions
    [n, 1]``, for the ``ppo`` strategy and the evaluation during training alike. A recurrent policy keeps the LSTM state
    of the batch it last acted on until :meth:`reset_state` (or a batch of another size).
    """

    def __init__(self, model, stats=None, config: dict[str, Any] | None = None, path: Path | None = None):
        self.model, self.stats, self.config, self.path = model, stats, config, path
        self.obs_dim = int(model.observation_space.shape[0])
        self.recurrent = hasattr(model.policy, "lstm_actor")
        self.state: tuple[np.ndarray, ...] | None = None
        if stats is not None and getattr(stats, "norm_obs", False):
            n = int(np.prod(stats.obs_rms.mean.shape))
            if n != self.obs_dim:
                raise ValueError(f"ppo: the observation statistics hold {n} entries but the model expects "
                                 f"{self.obs_dim}; they come from different runs")

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        return obs if self.stats is None else self.stats.normalize_obs(obs)

    def reset_state(self) -> None:
        """Forget the recurrent state: the next :meth:`act` starts new episodes."""
        self.state = None

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Deterministic motor shares u [n, 1] (clipped to [-1, 1]) for a batch of raw observations [n, dim]."""
        x = self.normalize(obs)
        if not self.recurrent:
            actions, _ = self.model.policy.predict(x, deterministic=True)
        else:
            fresh = self.state is None or self.state[0].shape[1] != len(x)
            actions, self.state = self.model.policy.predict(x, state=None if fresh else self.state,
                                                            episode_start=np.full(len(x), fresh), deterministic=True)
        return np.asarray(actions, dtype=np.float32).reshape(-1, 1)

    @property
    def env_settings(self) -> dict[str, Any]:
        return dict((self.config or {}).get("env") or {})


def load_policy(path: str | Path, *, normalize: bool = True) -> LoadedPolicy:
    """Load a trained policy: ``path`` a run directory or a model zip (see the module docstring)."""
    model_path = resolve_model_path(path)
    config = find_run_config(model_path)
    cfg = config or {}
    algo = str(cfg.get("algo", "ppo")).lower()
    if algo not in ALGORITHMS:
        raise ValueError(f"ppo: {model_path}: unknown algorithm {algo!r} in the run's config.yaml")
    norm_cfg = cfg.get("normalize")
    wants_stats = normalize and not (isinstance(norm_cfg, dict) and not norm_cfg.get("norm_obs", True))
    stats = load_obs_normalizer(stats_path_for(model_path)) if wants_stats else None
    model = load_sb3_model(model_path, algo, cfg.get("hyperparams"))
    warn_if_other_physics(model_path, config)
    return LoadedPolicy(model, stats, config, model_path)


def warn_if_other_physics(model_path: Path, config: dict[str, Any] | None) -> str | None:
    """Log one warning line (once) if the run's ``versions.physics_fingerprint`` is not today's
    (:func:`hev_thermal_env.physics.fingerprint.physics_fingerprint`); returns the warning, or None."""
    trained = ((config or {}).get("versions") or {}).get("physics_fingerprint")
    current = physics_fingerprint()
    if trained == current:
        return None
    what = "an unrecorded physics version" if trained is None else f"physics {trained}"
    message = (f"{model_path}: this policy was trained on {what}; the physics now is {current}: "
               "retrain it for figures that hold on today's physics")
    if message not in _WARNED:
        _WARNED.add(message)
        logging.getLogger("hev_thermal_env").warning(message)
    return message


_WARNED: set[str] = set()
