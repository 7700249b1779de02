"""``ppo``: a policy trained by ``train.py`` (Stable-Baselines3), behind the strategy protocol.

``get_strategy("ppo")`` loads the default policy shipped in ``agents/policies/ppo_default/``;
``get_strategy("ppo:PATH")`` or ``get_strategy("ppo", path=PATH)`` loads a trained run:

* a run directory of ``train.py`` (``DIR/model.zip``, the final model; if the run has not finished,
  ``DIR/best_model.zip``, else the latest checkpoint in ``DIR/checkpoints/``), or
* a model zip. Its observation statistics are looked up next to it: ``model.zip`` →
  ``vecnormalize.pkl``, ``best_model.zip`` → ``best_vecnormalize.pkl``, ``checkpoints/ckpt_N_steps.zip``
  → ``ckpt_N_steps_vecnormalize.pkl``, any other ``NAME.zip`` → ``NAME_vecnormalize.pkl`` or
  ``vecnormalize.pkl`` in the same directory.

The run's ``config.yaml`` (in the zip's directory or the run directory above ``checkpoints/``)
gives the algorithm (PPO or SAC: the strategy plays either) and the observation layout it was
trained on. :meth:`PPOStrategy.act` normalises the observation with the saved statistics (never
updating them) and predicts deterministically.

Errors are one-line messages: a missing model or statistics file raises ``FileNotFoundError``; an
unreadable one, or an environment whose observation differs from the one the model was trained on
(e.g. another ``preview_s``), raises ``ValueError`` naming what differs.
"""

from __future__ import annotations

import pickle
import re
import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .base import Strategy

DEFAULT_POLICY_DIR = Path(__file__).resolve().parent / "policies" / "ppo_default"
"""The shipped default policy (``get_strategy("ppo")``)."""

_CKPT_RE = re.compile(r"^ckpt_(\d+)_steps\.zip$")


# --- files of a trained policy ----------------------------------------------------------------------

def checkpoint_files(run_dir: Path) -> list[tuple[int, Path, Path]]:
    """Complete checkpoints of a run, oldest first: (timesteps, model zip, statistics pickle).

    A checkpoint counts once its model zip exists (it is written last, atomically)."""
    found = []
    ckpt_dir = Path(run_dir) / "checkpoints"
    if ckpt_dir.is_dir():
        for p in ckpt_dir.iterdir():
            m = _CKPT_RE.match(p.name)
            if m:
                found.append((int(m.group(1)), p, ckpt_dir / f"ckpt_{m.group(1)}_steps_vecnormalize.pkl"))
    return sorted(found)


def stats_path_for(model_path: Path) -> Path:
    """Where the observation statistics of ``model_path`` are saved (see the module docstring)."""
    model_path = Path(model_path)
    name = model_path.name
    if name == "model.zip":
        return model_path.with_name("vecnormalize.pkl")
    if name == "best_model.zip":
        return model_path.with_name("best_vecnormalize.pkl")
    own = model_path.with_name(model_path.stem + "_vecnormalize.pkl")
    if own.exists() or _CKPT_RE.match(name):
        return own
    return model_path.with_name("vecnormalize.pkl")


def resolve_model_path(path: str | Path) -> Path:
    """The model zip that ``path`` (a run directory or a zip) designates."""
    p = Path(path).expanduser()
    if p.is_dir():
        for name in ("model.zip", "best_model.zip"):
            if (p / name).is_file():
                return p / name
        ckpts = checkpoint_files(p)
        if ckpts:
            return ckpts[-1][1]
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


def load_sb3_model(path: Path, algo: str = "ppo"):
    """An SB3 model (PPO or SAC) from a zip on the CPU; raises one-line errors."""
    from .training import algorithm_class

    cls = algorithm_class(algo)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return cls.load(path, device="cpu")
    except Exception as exc:  # noqa: BLE001 - zip, pickle and torch errors all mean "unreadable model"
        if isinstance(exc, zipfile.BadZipFile) or not zipfile.is_zipfile(path):
            raise ValueError(f"ppo: {path} is not a model zip ({_one_line(exc)})") from None
        raise ValueError(f"ppo: cannot load {path} as an SB3 {algo.upper()} model ({_one_line(exc)})") from None


class LoadedPolicy:
    """A trained model and its observation statistics: ``act(obs [n, dim]) -> actions [n, 1]``.

    ``stats`` is a ``VecNormalize`` whose statistics are only read, or None (raw observations).
    """

    def __init__(self, model, stats=None, config: dict[str, Any] | None = None, path: Path | None = None):
        self.model = model
        self.stats = stats
        self.config = config
        self.path = path
        self.obs_dim = int(model.observation_space.shape[0])
        if stats is not None and getattr(stats, "norm_obs", False):
            n = int(np.prod(stats.obs_rms.mean.shape))
            if n != self.obs_dim:
                raise ValueError(f"ppo: the observation statistics hold {n} entries but the model expects "
                                 f"{self.obs_dim}; they come from different runs")

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        return obs if self.stats is None else self.stats.normalize_obs(obs)

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Deterministic motor shares u [n, 1] (clipped to [-1, 1]) for a batch of raw observations [n, dim]."""
        actions, _ = self.model.policy.predict(self.normalize(obs), deterministic=True)
        return np.asarray(actions, dtype=np.float32).reshape(-1, 1)

    @property
    def env_settings(self) -> dict[str, Any]:
        return dict((self.config or {}).get("env") or {})


def load_policy(path: str | Path | None = None, *, normalize: bool = True) -> LoadedPolicy:
    """Load a trained policy: ``path`` a run directory or a model zip (default: the shipped policy)."""
    model_path = resolve_model_path(DEFAULT_POLICY_DIR if path is None else path)
    config = find_run_config(model_path)
    algo = str((config or {}).get("algo", "ppo")).lower()
    if algo not in ("ppo", "sac"):
        raise ValueError(f"ppo: {model_path}: unknown algorithm {algo!r} in the run's config.yaml")
    stats = None
    norm_cfg = (config or {}).get("normalize")
    wants_stats = normalize and not (isinstance(norm_cfg, dict) and not norm_cfg.get("norm_obs", True))
    if wants_stats:
        stats = load_obs_normalizer(stats_path_for(model_path))
    model = load_sb3_model(model_path, algo)
    return LoadedPolicy(model, stats, config, model_path)


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
    names = settings.get("observation_names")
    env_names = getattr(e, "obs_names", None)
    if not differences and names and env_names and list(names) != list(env_names):
        first = next(i for i, (a, b) in enumerate(zip(names, env_names)) if a != b)
        differences.append(f"observation entry {first} is {names[first]!r} in training and {env_names[first]!r} here")
    if not differences:
        return None
    where = policy.path if policy.path is not None else "the model"
    return f"ppo: {where} does not match this environment: " + "; ".join(differences)


class PPOStrategy(Strategy):
    """A policy trained by ``train.py``; deterministic actions on normalised observations.

    Options: ``path`` (run directory or model zip; default the shipped ``ppo_default``) and
    ``normalize`` (False for a model trained without observation normalisation).
    """

    name = "ppo"

    def __init__(self, path: str | Path | None = None, normalize: bool = True):
        self.policy = load_policy(path, normalize=normalize)
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

    def reset(self, env: Any) -> None:
        super().reset(env)
        problem = observation_mismatch(self.policy, env)
        if problem:
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
        }

