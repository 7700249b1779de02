"""Behaviour cloning on an offline dataset: the datasets' usability check.

:func:`dataset_pairs` reads a Minari dataset (:mod:`hev_thermal_env.evaluation.datasets`) as (observation, action)
pairs; :func:`fit_bc` fits a small MLP (``torch``, MSE, Adam, full passes over the shuffled pairs, observations
standardised by the dataset's mean and spread) to them; :class:`BCStrategy` drives the env with it (the action
clipped to [-1, 1]) and is scored like any strategy (:func:`~hev_thermal_env.evaluation.submission.result_of_strategy`).
``evaluate.py bc`` trains one on a dataset and writes its result files for the leaderboard. A policy file
(:func:`save_bc`, :func:`load_bc`) holds the weights, the standardisation and the dataset's id and physics
fingerprint.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from hev_thermal_env.agents.base import Strategy
from hev_thermal_env.envs.reward import observation_options

from .fit import adam_passes

HIDDEN, EPOCHS, BATCH, LEARNING_RATE = (128, 128), 60, 256, 1e-3


def dataset_pairs(dataset: Any) -> tuple[np.ndarray, np.ndarray]:
    """Observations [N, dim] (those the actions were taken in) and actions [N] of every episode of ``dataset``."""
    obs, act = [], []
    for ep in dataset.iterate_episodes():
        obs.append(np.asarray(ep.observations[:-1], dtype=np.float32))
        act.append(np.asarray(ep.actions, dtype=np.float32).reshape(-1))
    return np.concatenate(obs), np.concatenate(act)


def _mlp(n_in: int, hidden: tuple[int, ...]) -> torch.nn.Sequential:
    layers: list[torch.nn.Module] = []
    for n in hidden:
        layers += [torch.nn.Linear(n_in, n), torch.nn.Tanh()]
        n_in = n
    return torch.nn.Sequential(*layers, torch.nn.Linear(n_in, 1))


def fit_bc(obs: np.ndarray, actions: np.ndarray, *, hidden: tuple[int, ...] = HIDDEN, epochs: int = EPOCHS,
           seed: int = 0) -> tuple[dict[str, Any], list[float]]:
    """Fit the MLP; returns its policy record (weights and standardisation) and the MSE of every pass."""
    torch.manual_seed(int(seed))
    mean, std = obs.mean(axis=0), np.maximum(obs.std(axis=0), 1e-6)
    x = torch.as_tensor((obs - mean) / std, dtype=torch.float32)
    y = torch.as_tensor(actions, dtype=torch.float32)
    net = _mlp(x.shape[1], tuple(hidden))
    opt = torch.optim.Adam(net.parameters(), lr=LEARNING_RATE)
    history = adam_passes(opt, len(x), epochs, seed, lambda idx: torch.mean((net(x[idx])[:, 0] - y[idx]) ** 2), BATCH)
    return {"state_dict": net.state_dict(), "hidden": list(hidden), "obs_mean": mean, "obs_std": std}, history


def dataset_env_options(dataset: Any) -> dict[str, Any]:
    """The env arguments of ``dataset``'s env that shape its observations beyond the task
    (:func:`~hev_thermal_env.envs.reward.observation_options`: a ``ppo`` source's env carries its policy's)."""
    spec = dataset.env_spec
    return observation_options(((spec.kwargs if spec is not None else None) or {}).get("reward"))


class BCStrategy(Strategy):
    """Drives with a behaviour-cloned MLP (a record of :func:`fit_bc` or :func:`load_bc`), in an env built with the
    options of the dataset it was fitted on (:func:`dataset_env_options`)."""

    name = "bc"

    def __init__(self, record: dict[str, Any], label: str = "bc"):
        self.record, self.label = record, label
        self.net = _mlp(len(record["obs_mean"]), tuple(record["hidden"]))
        self.net.load_state_dict(record["state_dict"])
        self.net.eval()
        self.mean, self.std = (np.asarray(record[k], dtype=np.float32) for k in ("obs_mean", "obs_std"))

    def env_options(self) -> dict[str, Any]:
        return dict(self.record.get("env_options") or {})

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        x = torch.as_tensor(((np.asarray(obs, dtype=np.float32) - self.mean) / self.std)[None])
        with torch.no_grad():
            u = float(self.net(x)[0, 0])
        return np.array([min(1.0, max(-1.0, u))], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        return {"name": self.label, "hidden": self.record["hidden"], "dataset": self.record.get("dataset")}


def save_bc(record: dict[str, Any], path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in record.items()}, path)
    return path


def load_bc(path: str | Path) -> dict[str, Any]:
    return torch.load(Path(path), weights_only=False)


def train_bc(dataset_id: str, *, epochs: int = EPOCHS, seed: int = 0) -> tuple[dict[str, Any], dict[str, Any]]:
    """Load ``dataset_id`` and fit a BC policy; returns its record and a report (pairs, MSE, seconds)."""
    import minari

    t0 = time.perf_counter()
    dataset = minari.load_dataset(dataset_id)
    obs, actions = dataset_pairs(dataset)
    record, history = fit_bc(obs, actions, epochs=epochs, seed=seed)
    meta = dataset.storage.metadata
    record.update(dataset=dataset_id, physics_fingerprint=meta.get("hev_thermal_physics_fingerprint"), seed=seed,
                  env_options=dataset_env_options(dataset))
    report = {"dataset": dataset_id, "pairs": int(len(actions)), "epochs": int(epochs), "seed": int(seed),
              "mse_first": round(history[0], 5), "mse_last": round(history[-1], 5),
              "action_variance": round(float(np.var(actions)), 5), "wall_s": round(time.perf_counter() - t0, 1)}
    return record, report
