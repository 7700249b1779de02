"""One trial of a sweep: the search space it is drawn from (samplers: ``python -m tools.sweep --help``; ``int``'s
bounds both included), its config, and the Ray Tune trainable, a ``train.py`` run in ``<trial dir>/run`` that reports
every evaluation with a snapshot of the run directory as the checkpoint, so a restored trial resumes it and ends where
an uninterrupted one would.
"""

from __future__ import annotations

import difflib
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hev_thermal_env.agents.policy_files import CHECKPOINTS, checkpoint_paths
from hev_thermal_env.io import read_yaml_mapping
from hev_thermal_env.training.config import build_config
from hev_thermal_env.training.hyperparams import is_number, parse_value
from hev_thermal_env.training.loop import TrainingRun, resume, train

METRIC = "eval_return_g"
TIME_ATTR = "timesteps"
#: The Tune config key of the seed index (set by Tune's ``Repeater`` or the seed grid).
SEED_INDEX = "__trial_index__"
RUN_DIR = "run"
SNAPSHOT_FILES = ("config.yaml", "command.txt", "evaluations.csv", "model.zip", "vecnormalize.pkl", "best_model.zip",
                  "best_vecnormalize.pkl")
SAMPLERS = ("uniform", "loguniform", "int", "choice")
_PPO_SPACE = {"learning_rate": {"loguniform": [1.0e-4, 1.0e-3]}, "gamma": {"uniform": [0.95, 0.99]},
              "gae_lambda": {"choice": [0.9, 0.95, 0.98]}, "clip_range": {"choice": [0.1, 0.2, 0.3]},
              "n_epochs": {"int": [3, 10]}}
_SAC_SPACE = {"learning_rate": {"loguniform": [1.0e-4, 1.0e-3]}, "gamma": {"uniform": [0.95, 0.99]},
              "tau": {"loguniform": [1.0e-3, 2.0e-2]}, "batch_size": {"choice": [128, 256, 512]}}
#: What ``python -m tools.sweep`` searches when no ``--space`` file is given.
DEFAULT_SPACES: dict[str, dict[str, Any]] = {"ppo": _PPO_SPACE, "sac": _SAC_SPACE, "tqc": _SAC_SPACE,
                                             "recurrent_ppo": _PPO_SPACE, "ppo_lagrangian": _PPO_SPACE}


def sampler_of(value: Any) -> str | None:
    """The sampler name of a space entry, or None for a fixed value."""
    if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in SAMPLERS:
        return next(iter(value))
    return None


def load_space(algo: str, path: str | Path | None = None, space: dict[str, Any] | None = None) -> dict[str, Any]:
    """The checked search space: ``space``, the one in the YAML file ``path``, or the default space of ``algo``."""
    where = "search space"
    if space is None and path is not None:
        space, where = read_yaml_mapping(path), str(path)
    if space is None:
        if algo not in DEFAULT_SPACES:
            raise ValueError(f"no default search space for {algo!r}; give one with --space FILE")
        return dict(DEFAULT_SPACES[algo])
    check_space(space, where)
    return space


def check_space(space: dict[str, Any], where: str = "search space") -> None:
    """One-line ``ValueError`` naming the key and value of a malformed sampler."""
    for key, value in space.items():
        kind = sampler_of(value)
        if kind is None:
            name = str(next(iter(value))) if isinstance(value, dict) and len(value) == 1 else ""
            close = difflib.get_close_matches(name, SAMPLERS, n=1) if name else []
            if close:  # {unifrom: [..]} is a misspelt sampler, not a mapping to fix
                raise ValueError(f"{where}: {key}: unknown sampler {name!r} (did you mean {close[0]!r}?)")
            continue
        args, problem = value[kind], None
        if kind == "choice":
            problem = None if isinstance(args, list) and args else "choice needs a non-empty list"
        elif not (isinstance(args, list) and len(args) == 2 and all(is_number(a) for a in args)):
            problem = f"{kind} needs [low, high] numbers"
        elif not float(args[0]) < float(args[1]):
            problem = f"{kind} needs low < high"
        elif kind == "loguniform" and float(args[0]) <= 0:
            problem = "loguniform needs positive bounds"
        elif kind == "int" and not all(float(a).is_integer() for a in args):
            problem = "int needs whole-number bounds"
        if problem:
            raise ValueError(f"{where}: {key}: {problem}, got {args!r}")


def tunable_keys(space: dict[str, Any]) -> list[str]:
    """The keys that vary, in the space's order."""
    return [k for k, v in space.items() if sampler_of(v) is not None]


def encode_choice(value: Any) -> str:
    """A choice as the text Optuna and Tune carry (``[64, 64]``, ``0.9``)."""
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).strip().removesuffix("...").strip()


def tune_space(space: dict[str, Any]) -> dict[str, Any]:
    """The Ray Tune search space of the varying keys."""
    from ray import tune

    out = {}
    for key in tunable_keys(space):
        kind, args = next(iter(space[key].items()))
        if kind == "choice":
            out[key] = tune.choice([encode_choice(v) for v in args])
        elif kind == "int":
            out[key] = tune.randint(int(args[0]), int(args[1]) + 1)
        else:
            out[key] = (tune.uniform if kind == "uniform" else tune.loguniform)(float(args[0]), float(args[1]))
    return out


def trial_overrides(space: dict[str, Any], sampled: dict[str, Any]) -> dict[str, Any]:
    """The ``--hp`` overrides of one trial: the fixed values, then the sampled ones (choices decoded)."""
    cast = {"choice": lambda v: parse_value(str(v)), "int": int, "uniform": float, "loguniform": float}
    fixed = {k: v for k, v in space.items() if sampler_of(v) is None}
    return {**fixed, **{k: cast[sampler_of(space[k])](sampled[k]) for k in tunable_keys(space)}}


def trial_config(settings: dict[str, Any], sampled: dict[str, Any]) -> dict[str, Any]:
    """The ``train.py`` config of the trial that Tune sampled (``sampled``: hyperparameters and seed index)."""
    overrides = {**settings["overrides"], **trial_overrides(settings["space"], sampled)}
    seed = int(settings["seed"]) + int(sampled.get(SEED_INDEX, 0))
    config = build_config(settings["algo"], hyperparams_file=settings["hyperparams_file"], overrides=overrides,
                          seed=seed, command=settings.get("command"), **settings["train"])
    # each evaluation writes its own checkpoint (see TuneTrainingRun); periodic ones would repeat them
    config["checkpoint_freq"] = config["total_timesteps"]
    return config


def probe_config(settings: dict[str, Any]) -> dict[str, Any]:
    """The config of a trial with the first value of every sampler (the low bound, the first choice): what
    every trial shares, built to check the settings before a sweep starts."""
    firsts = {k: next(iter(settings["space"][k].items())) for k in tunable_keys(settings["space"])}
    return trial_config(settings, {k: encode_choice(args[0]) if kind == "choice" else args[0]
                                   for k, (kind, args) in firsts.items()})


class TuneTrainingRun(TrainingRun):
    """A training session that reports its evaluations, each with a checkpoint, to Ray Tune."""

    def evaluate(self, model, logger=None):
        results = super().evaluate(model, logger)
        n = int(model.num_timesteps)
        if results and n < int(self.config["total_timesteps"]):  # the last one is reported after the final save
            self.checkpoint(model)
            self.report(results, n)
        return results

    def execute(self):
        result = super().execute()
        n = int(result["timesteps_done"])
        last = [r for r in self.eval_rows if r["timesteps"] == n]
        if last:
            self.report(last, n)
        return result

    def report(self, results: list[dict[str, Any]], timesteps: int) -> None:
        """``tune.report`` of one evaluation (a result per run) with a snapshot of the run directory at
        ``timesteps`` as the checkpoint: :data:`METRIC` (the mean return, g, higher is better) at :data:`TIME_ATTR`
        env-steps and the run's ``selection_score`` (lower is better)."""
        from ray import tune

        def mean(key):
            return float(np.mean([r[key] for r in results]))

        metrics = {METRIC: mean("return_g"), "fuel_corrected_l_per_100km": mean("fuel_corrected_l_per_100km"),
                   "delta_soc_max_abs": float(np.max(np.abs([r["delta_soc"] for r in results]))),
                   "cutoff_s": float(np.sum([r["cutoff_s"] for r in results])), TIME_ATTR: int(timesteps),
                   "selection_score": self.eval_rows[-1]["score"], "seed": int(self.config["seed"]),
                   "resumed_from_timesteps": int(self.resume_from[0]) if self.resume_from else 0}
        with tempfile.TemporaryDirectory(prefix="hev_sweep_ckpt_") as tmp:
            (Path(tmp) / CHECKPOINTS).mkdir()
            files = [self.out / name for name in SNAPSHOT_FILES] + list(checkpoint_paths(self.out, timesteps))
            for p in files:
                if p.is_file():
                    shutil.copy2(p, Path(tmp) / p.relative_to(self.out))
            tune.report(metrics, checkpoint=tune.Checkpoint.from_directory(tmp))


def sweep_trial(config: dict[str, Any], settings: dict[str, Any]) -> None:
    """The Ray Tune trainable: train (or, restored from a checkpoint, resume) one trial's run."""
    from ray import tune

    run_dir = Path(tune.get_context().get_trial_dir()) / RUN_DIR
    checkpoint = tune.get_checkpoint()
    if checkpoint is None:
        train(trial_config(settings, config), run_dir, progress=False, verbose=0, overwrite=True,
              run_class=TuneTrainingRun, log=lambda msg: None)
        return
    with checkpoint.as_directory() as snapshot:  # later checkpoints of the interrupted session are dropped
        shutil.rmtree(run_dir / CHECKPOINTS, ignore_errors=True)
        shutil.copytree(snapshot, run_dir, dirs_exist_ok=True)
    resume(run_dir, progress=False, verbose=0, run_class=TuneTrainingRun, log=lambda msg: None)
