"""Fitting a policy to demonstrations: the imitation's fit (:mod:`.imitation`) and behaviour cloning.

The imitation's loss (docs/training.md): the (weighted, :func:`fit_weights`) squared error of the policy's mean to the
teacher's action (:func:`fit_targets`), plus with ``init.cost_weight`` (1/g) > 0 what the action costs by the
teacher's own curve (:func:`cost_excess_g`, g per step). Behaviour cloning (``evaluate.py bc``): :func:`fit_bc` fits a
small MLP to a Minari dataset's pairs (:func:`dataset_pairs`), :class:`BCStrategy` drives with it (the action clipped
to [-1, 1]); its policy file (:func:`save_bc`) holds the weights, the standardisation, the dataset's id and
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

from ..envs.spaces import observation_names

#: The fit's batch size (the initial fit and the refit) and the initial fit's Adam learning rate.
BATCH, LEARNING_RATE = 1024, 1e-3
#: Behaviour cloning's MLP, passes, batch size and Adam learning rate.
BC_HIDDEN, BC_EPOCHS, BC_BATCH, BC_LEARNING_RATE = (128, 128), 60, 256, 1e-3


def near_derating(obs: np.ndarray, above_x: float) -> np.ndarray:
    """Which states (raw observations [N, dim]) lie near derating: their heat-index integrator (``heat_x``) above
    ``above_x`` (0: the motor derates; −0.05: where ``ecms_thermal``'s heat price starts, its ``x_thr``)."""
    return np.asarray(obs)[:, observation_names(0, 1).index("heat_x")] > above_x


def fit_weights(obs: np.ndarray, heat_weight: float, above_x: float) -> np.ndarray | None:
    """Each state's weight in the fit (float32): ``1 + heat_weight`` near derating (:func:`near_derating`), else 1;
    None (an unweighted fit) when ``heat_weight`` is 0. A plain fit errs most on those few states (docs/training.md)."""
    if float(heat_weight) == 0.0:
        return None
    return np.where(near_derating(obs, above_x), 1.0 + float(heat_weight), 1.0).astype(np.float32)


def cost_excess_g(mean: torch.Tensor, curves: torch.Tensor) -> torch.Tensor:
    """What each action of ``mean`` [B] costs above the teacher's cheapest candidate (g): ``curves`` [B, n] is the
    teacher's cost of n candidates evenly spaced on [-1, 1] above their cheapest, read at the action (clipped to the
    bounds, as the env clips it) by linear interpolation, so the charge has a gradient between the candidates."""
    n = curves.shape[1]
    pos = (torch.clamp(mean, -1.0, 1.0) + 1.0) * (0.5 * (n - 1))
    i0 = torch.clamp(torch.floor(pos.detach()), 0, n - 2).long()
    frac = pos - i0.to(pos.dtype)
    lo = torch.gather(curves, 1, i0[:, None])[:, 0]
    hi = torch.gather(curves, 1, (i0 + 1)[:, None])[:, 0]
    return lo + frac * (hi - lo)


def fit_loss(mean: torch.Tensor, target: torch.Tensor, weight: np.ndarray | None,
             curves: np.ndarray | None = None, cost_weight: float = 0.0) -> torch.Tensor:
    """The fit's loss on a batch: the MSE, or with weights Σ w (mean − target)² / Σ w; with ``cost_weight`` > 0 plus
    ``cost_weight`` · the mean :func:`cost_excess_g` of the batch's ``curves``. The run records it as
    ``mse_first``/``mse_last`` (the mean over a pass's batches)."""
    if weight is None:
        loss = torch.mean((mean - target) ** 2)
    else:
        w = torch.as_tensor(weight, device=mean.device)
        loss = torch.sum(w * (mean - target) ** 2) / torch.sum(w)
    if cost_weight > 0.0:
        if curves is None:
            raise ValueError("fit_loss: cost_weight > 0 needs the teacher's cost curves")
        loss = loss + float(cost_weight) * torch.mean(cost_excess_g(mean, torch.as_tensor(curves)))
    return loss


def fit_targets(actions: np.ndarray, high: float, beyond_bound: float) -> np.ndarray:
    """The teacher's actions as fitted: ``high + beyond_bound`` where the teacher sits at the upper bound (float32)."""
    return np.where(actions >= high, high + beyond_bound, actions).astype(np.float32)


def batch_loss(policy: Any, x: torch.Tensor, target: np.ndarray, rows: np.ndarray, weights: np.ndarray | None,
               curves: np.ndarray | None, cost_weight: float) -> torch.Tensor:
    """:func:`fit_loss` of ``policy``'s mean action on ``x``, the normalised observations of the demonstration steps
    ``rows`` (``target``, ``weights`` and ``curves`` are indexed by them): a batch of the fit or of the refit."""
    mean = policy.get_distribution(x).distribution.mean[:, 0]
    return fit_loss(mean, torch.as_tensor(target[rows]), None if weights is None else weights[rows],
                    None if curves is None else curves[rows], cost_weight)


def adam_step(opt: torch.optim.Optimizer, loss: torch.Tensor) -> float:
    """One step of ``opt`` down ``loss``; returns the loss."""
    opt.zero_grad()
    loss.backward()
    opt.step()
    return float(loss.detach())


def adam_passes(opt: torch.optim.Optimizer, n: int, epochs: int, seed: int, loss_of: Any,
                batch: int = BATCH) -> list[float]:
    """``epochs`` passes of ``opt`` over ``n`` samples in shuffled batches (``loss_of(indices)`` the loss of one, the
    order drawn from ``seed``): the one fitting loop of the imitation's fit and of behaviour cloning. Returns each
    pass's mean loss."""
    gen = torch.Generator().manual_seed(int(seed))
    history = []
    for _ in range(int(epochs)):
        perm = torch.randperm(n, generator=gen)
        total = 0.0
        for i in range(0, n, batch):
            idx = perm[i:i + batch]
            total += adam_step(opt, loss_of(idx)) * len(idx)
        history.append(total / n)
    return history


def fit_policy_mean(policy: Any, obs: np.ndarray, actions: np.ndarray, *, epochs: int, beyond_bound: float,
                    high: float, seed: int, weights: np.ndarray | None = None, curves: np.ndarray | None = None,
                    cost_weight: float = 0.0) -> list[float]:
    """Fit ``policy``'s mean action to ``actions`` on (already normalised) ``obs``, each state by its weight in
    ``weights`` (:func:`fit_weights`; None: all 1), with ``cost_weight`` > 0 also charged the teacher's cost
    ``curves`` [N, n] (:func:`cost_excess_g`); the loss of every pass."""
    for name, rows in (("weights", weights), ("cost curves", curves)):
        if rows is not None and len(rows) != len(actions):
            raise ValueError(f"fit_policy_mean: {len(rows)} {name} for {len(actions)} demonstration steps")
    target = fit_targets(actions, high, beyond_bound)
    x = torch.as_tensor(np.ascontiguousarray(obs, dtype=np.float32))
    opt = torch.optim.Adam(policy.parameters(), lr=LEARNING_RATE)
    policy.set_training_mode(True)
    history = adam_passes(opt, len(x), epochs, seed,
                          lambda idx: batch_loss(policy, x[idx], target, idx.numpy(), weights, curves, cost_weight))
    policy.set_training_mode(False)
    return history


def mean_cost_excess_g(policy: Any, obs: np.ndarray, curves: np.ndarray) -> float:
    """The mean :func:`cost_excess_g` (g per step) of ``policy``'s mean action on (already normalised) ``obs``: how
    much dearer than its teacher, by the teacher's own measure, the fitted policy acts on the demonstrations."""
    total = 0.0
    with torch.no_grad():
        for i in range(0, len(obs), BATCH):
            x = torch.as_tensor(np.ascontiguousarray(obs[i:i + BATCH], dtype=np.float32))
            mean = policy.get_distribution(x).distribution.mean[:, 0]
            total += float(cost_excess_g(mean, torch.as_tensor(curves[i:i + BATCH])).sum())
    return total / max(len(obs), 1)


def dataset_pairs(dataset: Any) -> tuple[np.ndarray, np.ndarray]:
    """Observations [N, dim] (those the actions were taken in) and actions [N] of every episode of ``dataset``."""
    episodes = list(dataset.iterate_episodes())
    return (np.concatenate([np.asarray(ep.observations[:-1], dtype=np.float32) for ep in episodes]),
            np.concatenate([np.asarray(ep.actions, dtype=np.float32).reshape(-1) for ep in episodes]))


def _mlp(n_in: int, hidden: tuple[int, ...]) -> torch.nn.Sequential:
    layers: list[torch.nn.Module] = []
    for n in hidden:
        layers += [torch.nn.Linear(n_in, n), torch.nn.Tanh()]
        n_in = n
    return torch.nn.Sequential(*layers, torch.nn.Linear(n_in, 1))


def fit_bc(obs: np.ndarray, actions: np.ndarray, *, epochs: int = BC_EPOCHS,
           seed: int = 0) -> tuple[dict[str, Any], list[float]]:
    """Fit the MLP; returns its policy record (weights and standardisation) and the MSE of every pass."""
    torch.manual_seed(int(seed))
    mean, std = obs.mean(axis=0), np.maximum(obs.std(axis=0), 1e-6)
    x = torch.as_tensor((obs - mean) / std, dtype=torch.float32)
    y = torch.as_tensor(actions, dtype=torch.float32)
    net = _mlp(x.shape[1], BC_HIDDEN)
    opt = torch.optim.Adam(net.parameters(), lr=BC_LEARNING_RATE)
    history = adam_passes(opt, len(x), epochs, seed, lambda i: torch.mean((net(x[i])[:, 0] - y[i]) ** 2), BC_BATCH)
    return {"state_dict": net.state_dict(), "hidden": list(BC_HIDDEN), "obs_mean": mean, "obs_std": std}, history


def dataset_env_options(dataset: Any) -> dict[str, Any]:
    """The env arguments of ``dataset``'s env that shape its observations beyond the task
    (:func:`~hev_thermal_env.envs.reward.observation_options`: a ``ppo`` source's env carries its policy's)."""
    return observation_options((getattr(dataset.env_spec, "kwargs", None) or {}).get("reward"))


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


def train_bc(dataset_id: str, *, epochs: int = BC_EPOCHS, seed: int = 0) -> tuple[dict[str, Any], dict[str, Any]]:
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
