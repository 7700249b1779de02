"""Sweeps: Ray Tune over hyperparameters and seeds, with the training of :mod:`.loop` as the trainable.

A sweep draws ``samples`` configurations from a search space (:mod:`.sweep_space`) with Optuna
(Ray Tune's ``OptunaSearch``) and trains each with ``seeds`` seeds (Tune's ``Repeater``: Optuna
learns from the mean over the seeds); a space without anything to search is a multi-seed study of
one configuration (the seeds as a grid). Every trial is a ``train.py`` run (:mod:`.sweep_trial`)
that reports its validation return at each evaluation, with a checkpoint; ASHA (or the median
stopping rule) stops the trials that fall behind. The sweep directory::

    DIR/sweep.yaml                     the sweep's settings (what --resume reads)
    DIR/tune/                          the Ray Tune experiment: one folder per trial, with its
    DIR/tune/trial_<id>/run/           train.py run directory and its Tune checkpoints
    DIR/sweep_trials.csv               one row per trial (hyperparameters, seed, status, metric)
    DIR/sweep_configs.csv, .md, .json  one row per configuration: IQM over seeds, 95 % bootstrap CI
    DIR/sweep.png                      validation curves and the seed spread of the best configurations
    DIR/best_policy/                   the best trial as a policy (ppo:DIR/best_policy)

An interrupted sweep (Ctrl-C, SIGUSR1, a lost driver) is continued by :func:`resume_sweep`: Tune
restores the finished trials, the search state and each unfinished trial from its last checkpoint.
On a cluster, ``DIR`` must be on storage every node sees at the same path (e.g. NFS).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

from hev_thermal_env.evaluation.executors import import_ray, start_ray
from hev_thermal_env.io import atomic_write_yaml, check_writable_dir, read_yaml_mapping

from .config import whole_number
from .loop import check_new_dir
from .sweep_report import SweepReport, collect_trials, export_best, write_report
from .sweep_space import check_space, load_space, probe_values, tunable_keys, tune_domains
from .sweep_trial import METRIC, MODE, SEED_INDEX, TIME_ATTR, sweep_trial, trial_config

ray = import_ray()
from ray import tune  # noqa: E402 - only once Ray is known to be installed
from ray.tune.experiment import Trial  # noqa: E402
from ray.tune.schedulers import ASHAScheduler, MedianStoppingRule  # noqa: E402
from ray.tune.search import Repeater  # noqa: E402
from ray.tune.search.optuna import OptunaSearch  # noqa: E402

SETTINGS_FILE = "sweep.yaml"
EXPERIMENT = "tune"
SCHEDULERS = ("asha", "median", "none")
#: Keyword arguments of :func:`~hev_thermal_env.training.config.build_config` a sweep passes to every trial.
TRAIN_KEYS = ("cycles", "scenario", "timesteps", "n_envs", "eval_cycles", "eval_scenarios", "eval_freq")


@dataclasses.dataclass
class SweepOutcome:
    """What a sweep call ended with."""

    complete: bool
    report: SweepReport
    exported: Path | None


def build_sweep(algo: str = "ppo", *, space_file: str | Path | None = None, space: dict | None = None,
                samples: int = 8, seeds: int = 3, seed: int = 0, scheduler: str = "asha",
                grace_timesteps: int | None = None, max_concurrent: int | None = None,
                hyperparams_file: str | None = None, overrides: dict | None = None, train: dict | None = None,
                command: str | None = None) -> dict[str, Any]:
    """The settings of a sweep (a plain dict, saved as ``sweep.yaml``), checked before any work."""
    algo = str(algo).lower()
    if space is None:
        space = load_space(space_file, algo)
    check_space(space)
    both = sorted(set(overrides or {}) & set(space))
    if both:
        raise ValueError(f"--hp {', '.join(both)}: also in the search space; set it in one place")
    unknown = sorted(set(train or {}) - set(TRAIN_KEYS))
    if unknown:
        raise ValueError(f"unknown sweep training setting(s) {', '.join(unknown)}; known: {', '.join(TRAIN_KEYS)}")
    train = {k: _absolute_paths(v) if k in ("cycles", "eval_cycles") else v for k, v in (train or {}).items()}
    settings = {"algo": algo, "space": dict(space), "samples": whole_number("samples", samples),
                "seeds": whole_number("seeds", seeds), "seed": whole_number("seed", seed), "scheduler": scheduler,
                "grace_timesteps": None if grace_timesteps is None else whole_number("grace", grace_timesteps),
                "max_concurrent": None if max_concurrent is None else whole_number("max_concurrent", max_concurrent),
                "hyperparams_file": None if hyperparams_file is None else str(Path(hyperparams_file).resolve()),
                "overrides": dict(overrides or {}),
                "train": {k: v for k, v in train.items() if v is not None}, "command": command}
    check_settings(settings)
    return settings


def _absolute_paths(cycles):
    """Cycle CSV paths made absolute (trials run in folders of their own, perhaps on other nodes)."""
    if cycles is None:
        return None
    return [str(Path(c).resolve()) if Path(c).is_file() else c for c in cycles]


def check_settings(settings: dict[str, Any]) -> dict[str, Any]:
    """One-line ``ValueError`` s for impossible settings; builds one trial's config to check every key."""
    for key in ("samples", "seeds"):
        if settings[key] < 1:
            raise ValueError(f"--{key} must be at least 1, got {settings[key]}")
    if settings["scheduler"] not in SCHEDULERS:
        raise ValueError(f"unknown --scheduler {settings['scheduler']!r}; choose one of {', '.join(SCHEDULERS)}")
    if settings["max_concurrent"] is not None and settings["max_concurrent"] < 1:
        raise ValueError(f"--max-concurrent must be at least 1, got {settings['max_concurrent']}")
    probe = trial_config(settings, probe_values(settings["space"]))
    if not probe["eval"]["cycles"] or not int(probe["eval"]["freq"]):
        raise ValueError("a sweep needs its validation metric: give evaluation cycles (--eval-cycles) and "
                         "--eval-freq > 0")
    if settings["grace_timesteps"] is not None and settings["grace_timesteps"] < 1:
        raise ValueError(f"--grace must be at least 1, got {settings['grace_timesteps']}")
    return probe


def load_settings(out: Path) -> dict[str, Any]:
    """The settings of the sweep in ``out`` (one-line errors when it is not a sweep directory)."""
    path = out / SETTINGS_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: {out} is not a sweep directory")
    settings = read_yaml_mapping(path)
    missing = [k for k in ("algo", "space", "samples", "seeds", "seed", "train", "overrides") if k not in settings]
    if missing:
        raise ValueError(f"{path}: not a sweep settings file (missing {', '.join(missing)})")
    if not (out / EXPERIMENT).is_dir():
        raise FileNotFoundError(f"{out / EXPERIMENT} not found: the sweep in {out} never started; start it again")
    return settings


def total_trials(settings: dict[str, Any]) -> int:
    return (settings["samples"] if tunable_keys(settings["space"]) else 1) * settings["seeds"]


class SweepProgress(tune.Callback):
    """A progress bar over the sweep's trials (finished or stopped early), with the best metric so far."""

    def __init__(self, enabled: bool = True):
        self.enabled = enabled
        self.bar = None
        self.shown = (0, None)

    def setup(self, stop=None, num_samples=None, total_num_samples=None, **info):
        self.bar = tqdm(total=total_num_samples, desc="sweep trials", unit="trial", disable=not self.enabled)

    def on_step_end(self, iteration, trials, **info):
        if self.bar is None:
            return
        done = sum(t.status in (Trial.TERMINATED, Trial.ERROR) for t in trials)
        scores = [t.last_result[METRIC] for t in trials if t.last_result and METRIC in t.last_result]
        best = max([*scores, *([] if self.shown[1] is None else [self.shown[1]])], default=None)
        if (done, best) != self.shown:
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
    return tune_domains(settings["space"]), Repeater(optuna, repeat=settings["seeds"], set_index=True), \
        settings["samples"] * settings["seeds"]


def _scheduler(settings: dict[str, Any], probe: dict[str, Any]):
    total = int(probe["total_timesteps"])
    grace = settings["grace_timesteps"] or min(total, 2 * int(probe["eval"]["freq"]))
    if settings["scheduler"] == "asha":
        return ASHAScheduler(time_attr=TIME_ATTR, max_t=total, grace_period=grace, reduction_factor=3)
    if settings["scheduler"] == "median":
        return MedianStoppingRule(time_attr=TIME_ATTR, grace_period=grace, min_samples_required=3)
    return None


def quiet_tune() -> None:
    """Tune's own console output off (the sweep has its progress bar and tables): its legacy reporter,
    which honours ``verbose=0``, no warning about frequent state snapshots (short trials make them)."""
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    os.environ.setdefault("TUNE_WARN_EXCESSIVE_EXPERIMENT_CHECKPOINT_SYNC_THRESHOLD_S", "0")
    # a trial that had not reported yet when the sweep was interrupted has no metrics to read
    logging.getLogger("ray.tune.analysis.experiment_analysis").setLevel(logging.ERROR)


def make_tuner(settings: dict[str, Any], out: Path, progress: bool = True, callbacks=()):
    """The Tune experiment of the sweep, stored in ``out/tune``."""
    probe = check_settings(settings)
    param_space, search_alg, num_samples = _search(settings)
    return tune.Tuner(
        _trainable(settings), param_space=param_space,
        tune_config=tune.TuneConfig(metric=METRIC, mode=MODE, search_alg=search_alg,
                                    scheduler=_scheduler(settings, probe), num_samples=num_samples,
                                    max_concurrent_trials=settings["max_concurrent"],
                                    trial_dirname_creator=trial_dirname),
        run_config=tune.RunConfig(name=EXPERIMENT, storage_path=str(out.resolve()), verbose=0,
                                  callbacks=[SweepProgress(progress), *callbacks],
                                  checkpoint_config=tune.CheckpointConfig(num_to_keep=2),
                                  failure_config=tune.FailureConfig(max_failures=1)))


def run_sweep(settings: dict[str, Any], out_dir: str | Path, *, address: str | None = None,
              num_cpus: int | None = None, progress: bool = True, export: str | Path | None = None,
              callbacks=()) -> SweepOutcome:
    """Run a new sweep into ``out_dir`` on a local Ray runtime of ``num_cpus`` CPUs or the cluster at ``address``."""
    out = check_new_dir(out_dir, "a sweep", SETTINGS_FILE)
    check_settings(settings)

    def fit():
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_yaml(out / SETTINGS_FILE, settings)
        make_tuner(settings, out, progress, callbacks).fit()

    return _on_ray(fit, settings, out, export, num_cpus, address)


def resume_sweep(out_dir: str | Path, *, address: str | None = None, num_cpus: int | None = None,
                 progress: bool = True, export: str | Path | None = None) -> SweepOutcome:
    """Continue the interrupted sweep in ``out_dir``: unfinished and failed trials from their last checkpoints."""
    out = Path(out_dir)
    settings = load_settings(out)
    check_settings(settings)
    check_writable_dir(out)

    def fit():
        tune.Tuner.restore(str((out / EXPERIMENT).resolve()), trainable=_trainable(settings), resume_unfinished=True,
                           resume_errored=True).fit()

    return _on_ray(fit, settings, out, export, num_cpus, address)


def _on_ray(fit, settings: dict[str, Any], out: Path, export: str | Path | None, num_cpus: int | None,
            address: str | None) -> SweepOutcome:
    """``fit()`` on Ray (started here unless already running), then the sweep's report and export."""
    quiet_tune()
    started = start_ray(ray, num_cpus, address)
    try:
        fit()
        return _finish(settings, out, export)
    finally:
        if started:
            ray.shutdown()


def _finish(settings: dict[str, Any], out: Path, export: str | Path | None) -> SweepOutcome:
    analysis = tune.ExperimentAnalysis(str((out / EXPERIMENT).resolve()), default_metric=METRIC, default_mode=MODE)
    trials = collect_trials(analysis, settings)
    complete = len(trials) == total_trials(settings) and all(t.status in ("finished", "stopped", "error")
                                                              for t in trials)
    report = write_report(out, trials, settings, complete=complete)
    exported = None
    if complete and report.best is not None:
        exported = export_best(report, Path(export) if export is not None else out / "best_policy", settings)
    return SweepOutcome(complete, report, exported)
