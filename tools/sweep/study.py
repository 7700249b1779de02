"""A sweep on Ray Tune: its settings (``sweep.yaml``), checked before any work, then the Tune run (new or resumed)
with the training of ``train.py`` as the trainable (:mod:`.trial`), and its report (:mod:`.report`).

Optuna draws ``samples`` configurations, each trained with ``seeds`` seeds; ASHA (or the median rule) stops trials
that fall behind.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

from hev_thermal_env.evaluation.executors import import_ray, start_ray
from hev_thermal_env.io import atomic_write_yaml, check_writable_dir, read_yaml_mapping
from hev_thermal_env.training.artifacts import check_new_dir
from hev_thermal_env.training.config import whole_number
from hev_thermal_env.training.hyperparams import check_known

from .report import SweepReport, collect_trials, export_best, write_report
from .trial import METRIC, SEED_INDEX, TIME_ATTR, load_space, probe_config, sweep_trial, tunable_keys, tune_space

ray = import_ray()
from ray import tune  # noqa: E402 - only once Ray is known to be installed
from ray.tune.experiment import Trial  # noqa: E402
from ray.tune.schedulers import ASHAScheduler, MedianStoppingRule  # noqa: E402
from ray.tune.search import Repeater  # noqa: E402
from ray.tune.search.optuna import OptunaSearch  # noqa: E402

MODE = "max"
SETTINGS_FILE = "sweep.yaml"
EXPERIMENT = "tune"
SCHEDULERS = ("asha", "median", "none")
#: Keyword arguments of :func:`~hev_thermal_env.training.config.build_config` a sweep passes to every trial.
TRAIN_KEYS = ("cycles", "scenario", "timesteps", "n_envs", "eval_cycles", "eval_scenarios", "eval_freq")


def build_sweep(algo: str = "ppo", *, space_file: str | Path | None = None, space: dict | None = None,
                samples: int = 8, seeds: int = 3, seed: int = 0, scheduler: str = "asha",
                grace_timesteps: int | None = None, max_concurrent: int | None = None,
                hyperparams_file: str | None = None, overrides: dict | None = None, train: dict | None = None,
                command: str | None = None) -> dict[str, Any]:
    """The settings of a sweep (a plain dict, saved as ``sweep.yaml``), checked before any work."""
    algo = str(algo).lower()
    space = load_space(algo, space_file, space)
    both = sorted(set(overrides or {}) & set(space))
    if both:
        raise ValueError(f"--hp {', '.join(both)}: also in the search space; set it in one place")
    check_known("sweep training setting", train or {}, TRAIN_KEYS)
    # cycle CSV paths made absolute: trials run in folders of their own, perhaps on other nodes
    train = {k: [str(Path(c).resolve()) if Path(c).is_file() else c for c in v] if k in ("cycles", "eval_cycles")
             and v is not None else v for k, v in (train or {}).items()}
    settings = {"algo": algo, "space": dict(space), "samples": whole_number("samples", samples),
                "seeds": whole_number("seeds", seeds), "seed": whole_number("seed", seed), "scheduler": scheduler,
                "grace_timesteps": None if grace_timesteps is None else whole_number("grace", grace_timesteps),
                "max_concurrent": None if max_concurrent is None else whole_number("max_concurrent", max_concurrent),
                "hyperparams_file": None if hyperparams_file is None else str(Path(hyperparams_file).resolve()),
                "overrides": dict(overrides or {}),
                "train": {k: v for k, v in train.items() if v is not None}, "command": command}
    check_settings(settings)
    return settings


def check_settings(settings: dict[str, Any]) -> dict[str, Any]:
    """One-line ``ValueError`` s for impossible settings; returns one trial's config (built to check every key)."""
    for key in ("samples", "seeds", "grace_timesteps", "max_concurrent"):
        if settings[key] is not None and settings[key] < 1:
            raise ValueError(f"--{key.removesuffix('_timesteps').replace('_', '-')} must be at least 1, "
                             f"got {settings[key]}")
    if settings["scheduler"] not in SCHEDULERS:
        raise ValueError(f"unknown --scheduler {settings['scheduler']!r}; choose one of {', '.join(SCHEDULERS)}")
    probe = probe_config(settings)
    if not probe["eval"]["cycles"] or not int(probe["eval"]["freq"]):
        raise ValueError("a sweep needs its validation metric: give evaluation cycles (--eval-cycles) and "
                         "--eval-freq > 0")
    return probe


def total_trials(settings: dict[str, Any]) -> int:
    return (settings["samples"] if tunable_keys(settings["space"]) else 1) * settings["seeds"]


class SweepProgress(tune.Callback):
    """A progress bar over the sweep's trials (finished, stopped early or failed), with the best metric so far."""

    def __init__(self, enabled: bool = True):
        self.enabled, self.bar, self.shown = enabled, None, (0, None)

    def setup(self, total_num_samples=None, **info):
        self.bar = tqdm(total=total_num_samples, desc="sweep trials", unit="trial", disable=not self.enabled)

    def on_step_end(self, iteration, trials, **info):
        done = sum(t.status in (Trial.TERMINATED, Trial.ERROR) for t in trials)
        scores = [t.last_result[METRIC] for t in trials if t.last_result and METRIC in t.last_result]
        best = max([*scores, *([] if self.shown[1] is None else [self.shown[1]])], default=None)
        if self.bar is not None and (done, best) != self.shown:
            self.bar.update(done - self.bar.n)
            running = sum(t.status == Trial.RUNNING for t in trials)
            if best is not None:
                self.bar.set_postfix_str(f"best {METRIC} so far {best:.1f}, {running} running")
            self.shown = (done, best)

    def on_experiment_end(self, trials, **info):
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __getstate__(self):  # Tune saves its callbacks with the experiment; a bar is not state
        return {**self.__dict__, "bar": None}


def trial_dirname(trial) -> str:
    return f"trial_{trial.trial_id}"


def _trainable(settings: dict[str, Any]):
    return tune.with_resources(tune.with_parameters(sweep_trial, settings=settings), {"cpu": 1})


def _search(settings: dict[str, Any]) -> tuple[dict[str, Any], Any, int]:
    """(param space, search algorithm, number of samples) of the sweep."""
    if not tunable_keys(settings["space"]):  # one configuration: its seeds as a grid
        return {SEED_INDEX: tune.grid_search(list(range(settings["seeds"])))}, None, 1
    optuna = OptunaSearch(seed=int(settings["seed"]))
    return tune_space(settings["space"]), Repeater(optuna, repeat=settings["seeds"], set_index=True), \
        settings["samples"] * settings["seeds"]


def _scheduler(settings: dict[str, Any], probe: dict[str, Any]):
    total = int(probe["total_timesteps"])
    grace = settings["grace_timesteps"] or min(total, 2 * int(probe["eval"]["freq"]))
    if settings["scheduler"] == "asha":
        return ASHAScheduler(time_attr=TIME_ATTR, max_t=total, grace_period=grace, reduction_factor=3)
    if settings["scheduler"] == "median":
        return MedianStoppingRule(time_attr=TIME_ATTR, grace_period=grace, min_samples_required=3)
    return None


def run_sweep(settings: dict[str, Any], out_dir: str | Path, *, address: str | None = None,
              num_cpus: int | None = None, progress: bool = True, export: str | Path | None = None) -> SweepReport:
    """Run a new sweep into ``out_dir`` on a local Ray runtime of ``num_cpus`` CPUs or the cluster at ``address``."""
    out = check_new_dir(out_dir, "a sweep", SETTINGS_FILE)
    probe = check_settings(settings)

    def fit():
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_yaml(out / SETTINGS_FILE, settings)
        param_space, search_alg, num_samples = _search(settings)
        tune.Tuner(_trainable(settings), param_space=param_space, tune_config=tune.TuneConfig(
            metric=METRIC, mode=MODE, search_alg=search_alg, scheduler=_scheduler(settings, probe),
            num_samples=num_samples, max_concurrent_trials=settings["max_concurrent"],
            trial_dirname_creator=trial_dirname), run_config=tune.RunConfig(
            name=EXPERIMENT, storage_path=str(out.resolve()), verbose=0, callbacks=[SweepProgress(progress)],
            checkpoint_config=tune.CheckpointConfig(num_to_keep=2), failure_config=tune.FailureConfig(max_failures=1),
        )).fit()

    return _on_ray(fit, settings, out, export, num_cpus, address)


def resume_sweep(out_dir: str | Path, *, address: str | None = None, num_cpus: int | None = None,
                 progress: bool = True, export: str | Path | None = None) -> SweepReport:
    """Continue the interrupted sweep in ``out_dir``: unfinished and failed trials from their last checkpoints."""
    out = Path(out_dir)
    path = out / SETTINGS_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: {out} is not a sweep directory")
    settings = read_yaml_mapping(path)
    missing = [k for k in ("algo", "space", "samples", "seeds", "seed", "train", "overrides") if k not in settings]
    if missing:
        raise ValueError(f"{path}: not a sweep settings file (missing {', '.join(missing)})")
    if not (out / EXPERIMENT).is_dir():
        raise FileNotFoundError(f"{out / EXPERIMENT} not found: the sweep in {out} never started; start it again")
    check_settings(settings)
    check_writable_dir(out)

    def fit():
        tune.Tuner.restore(str((out / EXPERIMENT).resolve()), trainable=_trainable(settings), resume_unfinished=True,
                           resume_errored=True).fit()

    return _on_ray(fit, settings, out, export, num_cpus, address)


def _on_ray(fit, settings: dict[str, Any], out: Path, export: str | Path | None, num_cpus: int | None,
            address: str | None) -> SweepReport:
    """``fit()`` on Ray (started here unless already running), then the sweep's report and export."""
    # Tune's own console output off (the sweep has its progress bar and tables): its legacy reporter, which
    # honours verbose=0, and no warning about frequent state snapshots (short trials make them)
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    os.environ.setdefault("TUNE_WARN_EXCESSIVE_EXPERIMENT_CHECKPOINT_SYNC_THRESHOLD_S", "0")
    # a trial that had not reported yet when the sweep was interrupted has no metrics to read
    logging.getLogger("ray.tune.analysis.experiment_analysis").setLevel(logging.ERROR)
    started = start_ray(ray, num_cpus, address)
    try:
        fit()
        analysis = tune.ExperimentAnalysis(str((out / EXPERIMENT).resolve()), default_metric=METRIC, default_mode=MODE)
        trials = collect_trials(analysis, settings)
        complete = len(trials) == total_trials(settings) and all(t.status in ("finished", "stopped", "error")
                                                                  for t in trials)
        report = write_report(out, trials, settings, complete=complete)
        if complete and report.best is not None:
            report.exported = export_best(report, Path(export) if export is not None else out / "best_policy",
                                          settings)
        return report
    finally:
        if started:
            ray.shutdown()
