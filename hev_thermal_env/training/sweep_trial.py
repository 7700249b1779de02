"""One trial of a sweep: a ``train.py`` run that reports each evaluation to Ray Tune with a checkpoint.

The trial's run directory is ``<trial dir>/run`` (a complete ``train.py`` run: ``ppo:PATH`` loads it,
``train.py --resume`` continues it). At every evaluation but the last the trial writes a checkpoint
of the run and reports the validation metrics to Tune with a *snapshot* of the run directory (its
config, evaluations, best model and the checkpoint just written; the final report adds the final
model) as the Tune checkpoint. A snapshot is itself a resumable run directory: a trial restored by
Tune (an interrupted sweep resumed, a failed worker) copies the snapshot back and continues with
:func:`~hev_thermal_env.training.loop.resume`, so it ends where an uninterrupted trial would.

The metric is the mean return over the evaluation cycles × scenarios (:data:`METRIC`, grams of
diesel equivalent, higher is better), at :data:`TIME_ATTR` env-steps; schedulers stop trials on it.
Each report also carries the run's checkpoint-selection score (``selection_score``, lower is better;
:mod:`.selection`).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.agents.policy_files import CHECKPOINTS, checkpoint_paths

from .config import build_config
from .loop import TrainingRun, resume, train
from .sweep_space import trial_overrides

METRIC = "eval_return_g"
MODE = "max"
TIME_ATTR = "timesteps"
#: The Tune config key of the seed index (set by Tune's ``Repeater`` or the seed grid).
SEED_INDEX = "__trial_index__"
RUN_DIR = "run"
SNAPSHOT_FILES = ("config.yaml", "command.txt", "evaluations.csv", "model.zip", "vecnormalize.pkl", "best_model.zip",
                  "best_vecnormalize.pkl")


def trial_config(settings: dict[str, Any], sampled: dict[str, Any]) -> dict[str, Any]:
    """The ``train.py`` config of the trial that Tune sampled (``sampled``: hyperparameters and seed index)."""
    overrides = {**settings["overrides"], **trial_overrides(settings["space"], sampled)}
    seed = int(settings["seed"]) + int(sampled.get(SEED_INDEX, 0))
    config = build_config(settings["algo"], hyperparams_file=settings["hyperparams_file"], overrides=overrides,
                          seed=seed, command=settings.get("command"), **settings["train"])
    # each evaluation writes its own checkpoint (see TuneTrainingRun); periodic ones would repeat them
    config["checkpoint_freq"] = config["total_timesteps"]
    return config


def eval_metrics(results: list[dict[str, Any]], timesteps: int) -> dict[str, Any]:
    """What a trial reports to Tune from one evaluation (one result per cycle × scenario)."""
    return {METRIC: float(np.mean([r["return_g"] for r in results])),
            "fuel_corrected_l_per_100km": float(np.mean([r["fuel_corrected_l_per_100km"] for r in results])),
            "delta_soc_max_abs": float(np.max(np.abs([r["delta_soc"] for r in results]))),
            "cutoff_s": float(np.sum([r["cutoff_s"] for r in results])),
            TIME_ATTR: int(timesteps)}


class TuneTrainingRun(TrainingRun):
    """A training session that reports its evaluations, each with a checkpoint, to Ray Tune."""

    resumed_from = 0

    def prepare(self, resume_from=None):
        self.resumed_from = int(resume_from[0]) if resume_from else 0
        return super().prepare(resume_from)

    def evaluate(self, model, logger=None):
        results = super().evaluate(model, logger)
        n = int(model.num_timesteps)
        if results and n < int(self.config["total_timesteps"]):  # the last one is reported after the final save
            self.checkpoint(model)
            self.report({**eval_metrics(results, n), "selection_score": self.eval_rows[-1]["score"]}, n)
        return results

    def execute(self):
        result = super().execute()
        n = int(result["timesteps_done"])
        last = [r for r in self.eval_rows if int(r["timesteps"]) == n]
        if last:
            self.report({**eval_metrics(last, n), "selection_score": last[-1]["score"]}, n)
        return result

    def report(self, metrics: dict[str, Any], timesteps: int) -> None:
        """``tune.report`` of ``metrics`` with a snapshot of the run directory at ``timesteps``."""
        from ray import tune

        metrics = {**metrics, "seed": int(self.config["seed"]), "resumed_from_timesteps": self.resumed_from}
        with tempfile.TemporaryDirectory(prefix="hev_sweep_ckpt_") as tmp:
            snapshot_run(self.out, Path(tmp), timesteps)
            tune.report(metrics, checkpoint=tune.Checkpoint.from_directory(tmp))


def snapshot_run(run_dir: Path, dest: Path, timesteps: int) -> Path:
    """Copy what resuming ``run_dir`` at ``timesteps`` needs into ``dest``."""
    (dest / CHECKPOINTS).mkdir(parents=True, exist_ok=True)
    for name in SNAPSHOT_FILES:
        if (run_dir / name).is_file():
            shutil.copy2(run_dir / name, dest / name)
    for p in checkpoint_paths(run_dir, timesteps):
        if p.is_file():
            shutil.copy2(p, dest / CHECKPOINTS / p.name)
    return dest


def restore_run(snapshot: Path, run_dir: Path) -> None:
    """Put a snapshot back as ``run_dir`` (later checkpoints of the interrupted session are dropped)."""
    shutil.rmtree(run_dir / CHECKPOINTS, ignore_errors=True)
    shutil.copytree(snapshot, run_dir, dirs_exist_ok=True)


def sweep_trial(config: dict[str, Any], settings: dict[str, Any]) -> None:
    """The Ray Tune trainable: train (or, restored from a checkpoint, resume) one trial's run."""
    from ray import tune

    run_dir = Path(tune.get_context().get_trial_dir()) / RUN_DIR
    checkpoint = tune.get_checkpoint()
    if checkpoint is not None:
        with checkpoint.as_directory() as snapshot:
            restore_run(Path(snapshot), run_dir)
        resume(run_dir, progress=False, verbose=0, run_class=TuneTrainingRun, log=lambda msg: None)
        return
    train(trial_config(settings, config), run_dir, progress=False, verbose=0, overwrite=True,
          run_class=TuneTrainingRun, log=lambda msg: None)
