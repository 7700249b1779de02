"""The files of a training run: the run directory, writing models and the evaluation table.

A run directory (rl-baselines3-zoo-like; written by :func:`hev_thermal_env.training.loop.train`)::

    DIR/model.zip, DIR/vecnormalize.pkl            final model and its observation/reward statistics
    DIR/best_model.zip, DIR/best_vecnormalize.pkl  best model on the evaluation cycles, with its statistics
    DIR/config.yaml, DIR/command.txt               the full config (incl. versions) and the command(s)
    DIR/checkpoints/ckpt_N_steps.zip (+ _vecnormalize.pkl, + _replay_buffer.pkl for SAC)
    DIR/evaluations.csv, DIR/training_curve.png    periodic deterministic evaluation, and its plot
    DIR/validation.csv                             best and final model on the full validation set
    DIR/tb/                                        TensorBoard logs

Models and statistics are written atomically, statistics first and the model last, so a present
model zip means a complete pair (:func:`save_model_and_stats`). Where a policy's files are and how
they are read (``load_policy``) is the policy format of :mod:`hev_thermal_env.agents.policy_files`.
"""

from __future__ import annotations

import csv
import io
import pickle
from pathlib import Path
from typing import Any

from hev_thermal_env.io import atomic_write_bytes, atomic_write_text

EVAL_COLUMNS = ("timesteps", "wall_s", "cycle", "scenario", "return_g", "fuel_corrected_l_per_100km", "delta_soc",
                "cutoff_s", "trace_miss_max_mps", "fuel_ratio", "mean_return_g", "score", "qualified", "best")
_FLAGS = ("qualified", "best")


def model_bytes(model, exclude_optimizer_state: bool = False) -> bytes:
    """The SB3 zip of ``model`` as bytes (optionally with a fresh optimizer state: a smaller file)."""
    buf = io.BytesIO()
    if exclude_optimizer_state:
        policy = model.policy
        saved = policy.optimizer
        policy.optimizer = type(saved)(policy.parameters(), **saved.defaults)
        try:
            model.save(buf)
        finally:
            policy.optimizer = saved
    else:
        model.save(buf)
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
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=EVAL_COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows({k: (int(r[k]) if k in _FLAGS else r[k]) for k in EVAL_COLUMNS} for r in rows)
    atomic_write_text(path, buf.getvalue())
