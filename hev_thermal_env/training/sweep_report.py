"""The results of a sweep: one row per trial, one per configuration (seeds summarised), a plot, the export.

A configuration's score is the interquartile mean (IQM) over its seeds of each trial's last
validation return, with a 95 % bootstrap confidence interval (``scipy.stats.bootstrap``, percentile
method, 2,000 resamples, fixed random seed; none for a single seed; both from
:mod:`hev_thermal_env.stats`). Trials stopped early by the scheduler count with the return they had
when stopped. The best configuration is the one with the highest IQM; the best trial is its seed
with the highest last return (among those that ran to the end, if any did), and its final model
(the latest checkpoint when stopped early) is exported as a policy that ``ppo:PATH`` loads.
"""

from __future__ import annotations

import csv
import dataclasses
import io
from pathlib import Path
from typing import Any

from hev_thermal_env.agents.policy_files import checkpoint_files
from hev_thermal_env.evaluation.results_table import _fmt  # the benchmark tables' cell format
from hev_thermal_env.io import atomic_write_json, atomic_write_text
from hev_thermal_env.stats import CONFIDENCE, iqm, iqm_ci

from .export import export_policy
from .sweep_space import probe_values, trial_overrides, tunable_keys
from .sweep_trial import METRIC, RUN_DIR, SEED_INDEX, TIME_ATTR, trial_config

#: Tune's trial statuses, as the tables name them ("stopped" = stopped early by the scheduler).
STATUS = {"TERMINATED": "finished", "ERROR": "error", "RUNNING": "running", "PENDING": "pending",
          "PAUSED": "paused"}


@dataclasses.dataclass
class TrialRecord:
    trial_id: str
    config_id: str
    hyperparams: dict[str, Any]
    seed: int
    status: str
    timesteps: int
    score: float | None
    best_score: float | None
    fuel_corrected_l_per_100km: float | None
    curve: list[tuple[int, float]]
    checkpoint: Path | None
    run_dir: Path


@dataclasses.dataclass
class ConfigSummary:
    config_id: str
    hyperparams: dict[str, Any]
    trial_ids: list[str]
    scores: list[float]
    iqm: float | None
    ci_low: float | None
    ci_high: float | None
    fuel_iqm: float | None


@dataclasses.dataclass
class SweepReport:
    trials: list[TrialRecord]
    configs: list[ConfigSummary]  # best first
    best: TrialRecord | None
    files: list[Path]


def collect_trials(analysis, settings: dict[str, Any]) -> list[TrialRecord]:
    """One record per trial of a Tune ``ExperimentAnalysis`` (configurations numbered by first appearance)."""
    keys = tunable_keys(settings["space"])
    total = int(trial_config(settings, probe_values(settings["space"]))["total_timesteps"])
    ids: dict[str, str] = {}
    records = []
    for t in analysis.trials:
        hp = trial_overrides(settings["space"], t.config) if keys else {}
        hp = {k: hp[k] for k in keys}
        config_id = ids.setdefault(repr(sorted(hp.items())), f"c{len(ids)}")
        df = analysis.trial_dataframes.get(t.trial_id)
        curve = []
        if df is not None and not df.empty and METRIC in df:
            curve = [(int(n), float(v)) for n, v in zip(df[TIME_ATTR], df[METRIC])]
        last = t.last_result or {}
        timesteps = int(last.get(TIME_ATTR) or 0)
        status = STATUS.get(t.status, t.status.lower())
        if status == "finished" and timesteps < total:
            status = "stopped"
        ckpt = t.checkpoint
        records.append(TrialRecord(
            trial_id=t.trial_id, config_id=config_id, hyperparams=hp,
            seed=int(settings["seed"]) + int(t.config.get(SEED_INDEX, 0)), status=status, timesteps=timesteps,
            score=float(last[METRIC]) if METRIC in last else None,
            best_score=max((v for _, v in curve), default=None),
            fuel_corrected_l_per_100km=last.get("fuel_corrected_l_per_100km"), curve=curve,
            checkpoint=Path(ckpt.path) if ckpt is not None else None, run_dir=Path(t.path) / RUN_DIR))
    return records


def summarise(trials: list[TrialRecord]) -> list[ConfigSummary]:
    """One summary per configuration, best IQM first (configurations without a score last)."""
    groups: dict[str, list[TrialRecord]] = {}
    for t in trials:
        groups.setdefault(t.config_id, []).append(t)
    out = []
    for config_id, members in groups.items():
        scored = [t for t in members if t.score is not None]
        scores = [t.score for t in scored]
        fuels = [t.fuel_corrected_l_per_100km for t in scored if t.fuel_corrected_l_per_100km is not None]
        low, high = iqm_ci(scores)
        out.append(ConfigSummary(config_id, members[0].hyperparams, [t.trial_id for t in members], scores,
                                 iqm(scores) if scores else None, low, high, iqm(fuels) if fuels else None))
    return sorted(out, key=lambda c: (c.iqm is None, -(c.iqm or 0.0)))


def best_trial(trials: list[TrialRecord], configs: list[ConfigSummary]) -> TrialRecord | None:
    """The seed with the highest last return in the configuration with the highest IQM (a trial that ran to
    the end before one stopped early)."""
    if not configs or configs[0].iqm is None:
        return None
    members = [t for t in trials if t.config_id == configs[0].config_id and t.score is not None]
    return max(members, key=lambda t: (t.status == "finished", t.score))


def write_report(out: Path, trials: list[TrialRecord], settings: dict[str, Any], complete: bool = True) -> SweepReport:
    """``sweep_trials.csv``, ``sweep_configs.csv/.md/.json`` and ``sweep.png`` in ``out``."""
    configs = summarise(trials)
    best = best_trial(trials, configs)
    keys = tunable_keys(settings["space"])
    files = [_write_trials_csv(out / "sweep_trials.csv", trials, keys)]
    files += _write_configs(out, configs, keys, best, complete)
    if any(t.curve for t in trials):
        from .sweep_plot import plot_sweep

        files.append(plot_sweep(trials, configs, best, out / "sweep.png"))
    return SweepReport(trials, configs, best, files)


def _write_trials_csv(path: Path, trials: list[TrialRecord], keys: list[str]) -> Path:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["trial_id", "config_id", *keys, "seed", "status", TIME_ATTR, METRIC, f"best_{METRIC}",
                "fuel_corrected_l_per_100km", "checkpoint", "run_dir"])
    for t in trials:
        w.writerow([t.trial_id, t.config_id, *(_fmt(t.hyperparams[k]) for k in keys), t.seed, t.status, t.timesteps,
                    _fmt(t.score), _fmt(t.best_score), _fmt(t.fuel_corrected_l_per_100km), _fmt(t.checkpoint),
                    t.run_dir])
    return atomic_write_text(path, buf.getvalue())


def _write_configs(out: Path, configs: list[ConfigSummary], keys: list[str], best: TrialRecord | None,
                   complete: bool) -> list[Path]:
    head = ["config_id", *keys, "seeds", f"{METRIC}_iqm", "ci95_low", "ci95_high", "fuel_corrected_l_per_100km_iqm"]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(head)
    md = ["| " + " | ".join(["config", *keys, "seeds", "validation return IQM (g)", "95 % CI",
                             "corrected fuel IQM (L/100 km)"]) + " |", "|" + "---|" * (len(keys) + 5)]
    for c in configs:
        w.writerow([c.config_id, *(_fmt(c.hyperparams[k]) for k in keys), len(c.scores), _fmt(c.iqm), _fmt(c.ci_low),
                    _fmt(c.ci_high), _fmt(c.fuel_iqm)])
        ci = f"[{c.ci_low:.1f}, {c.ci_high:.1f}]" if c.ci_low is not None else "-"
        md.append("| " + " | ".join([c.config_id, *(_fmt(c.hyperparams[k]) for k in keys), str(len(c.scores)),
                                     f"{c.iqm:.1f}" if c.iqm is not None else "-", ci,
                                     f"{c.fuel_iqm:.3f}" if c.fuel_iqm is not None else "-"]) + " |")
    md += ["", f"Validation return: mean episode return (g of diesel equivalent, higher is better) over the "
           f"evaluation cycles, at each trial's last evaluation; IQM and {100 * CONFIDENCE:.0f} % bootstrap "
           f"interval over the seeds."]
    if best is not None:
        md.append(f"Best trial: {best.trial_id} ({best.config_id}, seed {best.seed}, {best.status}, "
                  f"{METRIC} {best.score:.1f}).")
    if not complete:
        md.append("The sweep is not complete: continue it with `train.py sweep --resume DIR`.")
    data = {"metric": METRIC, "complete": complete, "best_trial": best.trial_id if best else None,
            "configs": [dataclasses.asdict(c) for c in configs]}
    return [atomic_write_text(out / "sweep_configs.csv", buf.getvalue()),
            atomic_write_text(out / "sweep_configs.md", "\n".join(md) + "\n"),
            atomic_write_json(out / "sweep_configs.json", data)]


def export_best(report: SweepReport, dest: Path, settings: dict[str, Any]) -> Path:
    """Export the best trial's final model (from its latest Tune checkpoint) as a policy package in ``dest``."""
    best = report.best
    source = best.checkpoint if best.checkpoint is not None else best.run_dir
    model = source / "model.zip"
    if not model.is_file():
        ckpts = checkpoint_files(source)
        if not ckpts:
            raise FileNotFoundError(f"no model in the best trial's checkpoint {source}")
        model = ckpts[-1][1]
    config = next(c for c in report.configs if c.config_id == best.config_id)
    lines = [f"# Best trial of a sweep ({settings['algo']})", "",
             f"Trial {best.trial_id}, configuration {best.config_id}, seed {best.seed}, {best.timesteps} env-steps "
             f"({best.status}); validation return {best.score:.1f} g; configuration IQM over "
             f"{len(config.scores)} seed(s) {config.iqm:.1f} g.", "", "Hyperparameters searched:", ""]
    lines += [f"- `{k}`: {v!r}" for k, v in best.hyperparams.items()] or ["- (none: a multi-seed study)"]
    return export_policy(model, dest, readme="\n".join(lines) + "\n")
