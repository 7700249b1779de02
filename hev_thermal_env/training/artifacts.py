"""The files of a run directory (docs/training.md lists them): its creation (:func:`check_new_dir`), models,
``evaluations.csv``, and a trained policy exported as a small package (:func:`export_policy`). Models and statistics
are written atomically, statistics first and the model last, so a present model zip means a complete pair.
"""

from __future__ import annotations

import csv
import io
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch

from hev_thermal_env.agents.policy_files import (
    find_run_config,
    load_obs_normalizer,
    load_sb3_model,
    resolve_model_path,
    stats_path_for,
)
from hev_thermal_env.io import atomic_write_bytes, atomic_write_text, check_writable_dir

from .config import save_run_config

EVAL_COLUMNS = ("timesteps", "wall_s", "cycle", "scenario", "return_g", "fuel_corrected_l_per_100km", "delta_soc",
                "cutoff_s", "trace_miss_max_mps", "fuel_ratio", "mean_return_g", "score", "qualified", "best")
_FLAGS = ("qualified", "best")


def model_bytes(model, exclude_optimizer_state: bool = False) -> bytes:
    """The SB3 zip of ``model`` as bytes (optionally with fresh optimizer states: a smaller file). The optimizers are
    those of the policy's networks: the policy's own (PPO, RecurrentPPO) or its actor's and critic's (SAC, TQC)."""
    buf = io.BytesIO()
    if not exclude_optimizer_state:
        model.save(buf)
        return buf.getvalue()
    owners = [m for m in model.policy.modules() if isinstance(getattr(m, "optimizer", None), torch.optim.Optimizer)]
    saved = [m.optimizer for m in owners]
    for owner, optimizer in zip(owners, saved):
        params = [p for group in optimizer.param_groups for p in group["params"]]
        owner.optimizer = type(optimizer)(params, **optimizer.defaults)
    try:
        model.save(buf)
    finally:
        for owner, optimizer in zip(owners, saved):
            owner.optimizer = optimizer
    return buf.getvalue()


def save_model_and_stats(model, stats, model_path: Path, stats_path: Path) -> None:
    """Statistics first, the model last, each atomically: a present model zip means a complete pair."""
    if stats is not None:
        atomic_write_bytes(stats_path, pickle.dumps(stats))
    atomic_write_bytes(model_path, model_bytes(model))


def read_evaluations(path: Path) -> list[dict[str, Any]]:
    """The rows of ``evaluations.csv`` (typed), or [] when there is none yet."""
    if not path.is_file():
        return []
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r.update({k: float(r[k]) for k in EVAL_COLUMNS if k not in ("timesteps", "cycle", "scenario", *_FLAGS)})
        r.update({k: r[k] == "1" for k in _FLAGS}, timesteps=int(float(r["timesteps"])))
    return rows


def write_evaluations(path: Path, rows: list[dict[str, Any]]) -> None:
    write_csv(path, EVAL_COLUMNS, [[int(r[k]) if k in _FLAGS else r[k] for k in EVAL_COLUMNS] for r in rows])


def write_csv(path: Path, head: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
    """A CSV file of ``rows`` under the header ``head``, written atomically."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows([head, *rows])
    return atomic_write_text(path, buf.getvalue())


def check_new_dir(out_dir: str | Path, holds: str = "a run", marker: str = "config.yaml",
                  overwrite: bool = False) -> Path:
    """``out_dir`` can receive a new run (or sweep: ``holds``, with its settings file ``marker``): new or empty
    (or ``overwrite``), and writable."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out}: exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        if (out / marker).is_file():
            raise ValueError(f"--out {out} already holds {holds}; continue it with --resume {out} or choose "
                             f"another directory")
        raise ValueError(f"--out {out} is not empty; choose an empty or new directory")
    return check_writable_dir(out)


def export_policy(run: str | Path, out_dir: str | Path, readme: str | None = None) -> Path:
    """Copy a trained policy into ``out_dir`` as a small package (how ``agents/policies/ppo_default/`` was made):
    ``model.zip`` (without the optimizer's state), ``vecnormalize.pkl`` and ``config.yaml`` (and ``README.md`` if
    given)."""
    model_path = resolve_model_path(run)
    config = find_run_config(model_path)
    if config is None:
        raise FileNotFoundError(f"no config.yaml next to {model_path}: export needs a train.py run")
    model = load_sb3_model(model_path, config["algo"], config.get("hyperparams"))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if config["normalize"] is not False:
        stats_path = stats_path_for(model_path)
        load_obs_normalizer(stats_path)  # checks it
        atomic_write_bytes(out / "vecnormalize.pkl", stats_path.read_bytes())
    atomic_write_bytes(out / "model.zip", model_bytes(model, exclude_optimizer_state=True))
    config = {**config, "exported_from": {"model": model_path.name, "timesteps": int(model.num_timesteps)}}
    save_run_config(out, config)
    if readme is not None:
        atomic_write_text(out / "README.md", readme)
    return out
