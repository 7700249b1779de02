"""A sweep's report: one record per trial, one summary per configuration (the IQM over its seeds of each trial's
last validation return, with a 95 % bootstrap interval), the tables and figure, and the export of the best
configuration's best seed (docs/scaling-out.md)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from matplotlib.ticker import MaxNLocator

from hev_thermal_env.agents.policy_files import checkpoint_files
from hev_thermal_env.evaluation.results_table import _fmt, _table  # the benchmark tables' cells and layout
from hev_thermal_env.evaluation.styles import pyplot, save_fig
from hev_thermal_env.io import atomic_write_json, atomic_write_text
from hev_thermal_env.stats import CONFIDENCE, iqm, iqm_ci
from hev_thermal_env.training.artifacts import export_policy, write_csv

from .trial import METRIC, RUN_DIR, SEED_INDEX, TIME_ATTR, probe_config, trial_overrides, tunable_keys

#: Configurations shown in the right panel of ``sweep.png`` (best first).
MAX_CONFIGS_SHOWN = 12


@dataclasses.dataclass
class TrialRecord:
    """One trial; ``status`` is Tune's in lower case, ``finished`` for a trial that ran to the end and ``stopped``
    for one the scheduler stopped early; ``score`` is the last validation return, ``curve`` all of them."""

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
    """What a sweep ended with: ``configs`` best first; ``exported``: where the best trial's policy went (None: not
    exported)."""

    trials: list[TrialRecord]
    configs: list[ConfigSummary]
    best: TrialRecord | None
    complete: bool
    exported: Path | None = None


def creation_order(trials: list[Any]) -> list[Any]:
    """Tune's trials in the order they were created (the number that starts each ``experiment_tag``): a restored
    experiment lists them in another order, and the configurations are numbered by first appearance. A trial without
    that number keeps its place after the numbered ones."""
    def number(trial: Any) -> float:
        head = str(getattr(trial, "experiment_tag", "") or "").split("_", 1)[0]
        return int(head) if head.isdigit() else float("inf")

    return sorted(trials, key=number)


def collect_trials(analysis, settings: dict[str, Any]) -> list[TrialRecord]:
    """One record per trial of a Tune ``ExperimentAnalysis`` (configurations numbered by first appearance, the trials
    in the order they were created: :func:`creation_order`)."""
    keys = tunable_keys(settings["space"])
    total = int(probe_config(settings)["total_timesteps"])
    ids: dict[str, str] = {}
    records = []
    for t in creation_order(analysis.trials):
        hp = {k: v for k, v in trial_overrides(settings["space"], t.config).items() if k in keys}
        config_id = ids.setdefault(repr(sorted(hp.items())), f"c{len(ids)}")
        df = analysis.trial_dataframes.get(t.trial_id)
        reported = df is not None and not df.empty and METRIC in df
        curve = [(int(n), float(v)) for n, v in zip(df[TIME_ATTR], df[METRIC])] if reported else []
        last = t.last_result or {}
        timesteps = int(last.get(TIME_ATTR) or 0)
        status = "finished" if t.status == "TERMINATED" else t.status.lower()
        if status == "finished" and timesteps < total:
            status = "stopped"
        records.append(TrialRecord(
            t.trial_id, config_id, hp, int(settings["seed"]) + int(t.config.get(SEED_INDEX, 0)), status, timesteps,
            float(last[METRIC]) if METRIC in last else None, max((v for _, v in curve), default=None),
            last.get("fuel_corrected_l_per_100km"), curve, Path(t.checkpoint.path) if t.checkpoint else None,
            Path(t.path) / RUN_DIR))
    return records


def summarise(trials: list[TrialRecord]) -> list[ConfigSummary]:
    """One summary per configuration, best IQM first (configurations without a score last)."""
    groups: dict[str, list[TrialRecord]] = {}
    for t in trials:
        groups.setdefault(t.config_id, []).append(t)
    out = []
    for config_id, members in groups.items():
        scores = [t.score for t in members if t.score is not None]
        fuels = [t.fuel_corrected_l_per_100km for t in members
                 if t.score is not None and t.fuel_corrected_l_per_100km is not None]
        out.append(ConfigSummary(config_id, members[0].hyperparams, [t.trial_id for t in members], scores,
                                 iqm(scores) if scores else None, *iqm_ci(scores), iqm(fuels) if fuels else None))
    return sorted(out, key=lambda c: (c.iqm is None, -(c.iqm or 0.0)))


def write_report(out: Path, trials: list[TrialRecord], settings: dict[str, Any], complete: bool = True) -> SweepReport:
    """``sweep_trials.csv``, ``sweep_configs.csv/.md/.json`` and ``sweep.png`` in ``out``."""
    configs = summarise(trials)
    best = None  # the best configuration's seed with the highest last return, one that ran to the end first
    if configs and configs[0].iqm is not None:
        best = max((t for t in trials if t.config_id == configs[0].config_id and t.score is not None),
                   key=lambda t: (t.status == "finished", t.score))
    keys = tunable_keys(settings["space"])
    write_csv(out / "sweep_trials.csv", ["trial_id", "config_id", *keys, "seed", "status", TIME_ATTR, METRIC,
                                          f"best_{METRIC}", "fuel_corrected_l_per_100km", "checkpoint", "run_dir"],
              [[t.trial_id, t.config_id, *(_fmt(t.hyperparams[k]) for k in keys), t.seed, t.status, t.timesteps,
                _fmt(t.score), _fmt(t.best_score), _fmt(t.fuel_corrected_l_per_100km), _fmt(t.checkpoint), t.run_dir]
               for t in trials])
    rows, lines = [], []
    for c in configs:
        hp = [_fmt(c.hyperparams[k]) for k in keys]
        rows.append([c.config_id, *hp, len(c.scores), _fmt(c.iqm), _fmt(c.ci_low), _fmt(c.ci_high), _fmt(c.fuel_iqm)])
        lines.append([c.config_id, *hp, str(len(c.scores)), "-" if c.iqm is None else f"{c.iqm:.1f}",
                      "-" if c.ci_low is None else f"[{c.ci_low:.1f}, {c.ci_high:.1f}]",
                      "-" if c.fuel_iqm is None else f"{c.fuel_iqm:.3f}"])
    md = _table(["config", *keys, "seeds", "validation return IQM (g)", "95 % CI", "corrected fuel IQM (L/100 km)"],
                lines)
    md += ["", f"Validation return: mean episode return (g of diesel equivalent, higher is better) over the "
           f"evaluation cycles, at each trial's last evaluation; IQM and {100 * CONFIDENCE:.0f} % bootstrap "
           f"interval over the seeds."]
    if best is not None:
        md.append(f"Best trial: {best.trial_id} ({best.config_id}, seed {best.seed}, {best.status}, "
                  f"{METRIC} {best.score:.1f}).")
    if not complete:
        md.append("The sweep is not complete: continue it with `python -m tools.sweep --resume DIR`.")
    write_csv(out / "sweep_configs.csv", ["config_id", *keys, "seeds", f"{METRIC}_iqm", "ci95_low", "ci95_high",
                                           "fuel_corrected_l_per_100km_iqm"], rows)
    atomic_write_text(out / "sweep_configs.md", "\n".join(md) + "\n")
    atomic_write_json(out / "sweep_configs.json", {"metric": METRIC, "complete": complete,
                                                   "best_trial": best.trial_id if best else None,
                                                   "configs": [dataclasses.asdict(c) for c in configs]})
    if any(t.curve for t in trials):
        plot_sweep(trials, configs, best, out / "sweep.png", METRIC)
    return SweepReport(trials, configs, best, complete)


def export_best(report: SweepReport, dest: Path, settings: dict[str, Any]) -> Path:
    """Export the best trial of a sweep's report as a policy package in ``dest``: its final model, from its latest
    Tune checkpoint (the latest training checkpoint of a trial stopped early)."""
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


def plot_sweep(trials: list[Any], configs: list[Any], best: Any, path: Path, metric: str) -> Path:
    """A sweep's figure (the trial records and configuration summaries, best first; ``best``: the best
    trial or None), a PNG at ``path``. Left: the validation return over env-steps per trial (the best configuration
    drawn thick, trials stopped early dashed). Right: per configuration, each seed's last ``metric`` (dots), the IQM
    (bar) and its 95 % bootstrap interval (whiskers)."""
    plt = pyplot()
    shown = [c for c in configs if c.iqm is not None][:MAX_CONFIGS_SHOWN]
    colours = {c.config_id: plt.cm.tab10(i % 10) for i, c in enumerate(shown)}
    fig, (ax_curve, ax_seeds) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    best_config = best.config_id if best is not None else None
    for t in trials:
        if t.curve:
            ax_curve.plot(*zip(*t.curve), color=colours.get(t.config_id, "0.7"),
                          lw=2.4 if t.config_id == best_config else 1.0, ls="--" if t.status == "stopped" else "-",
                          marker="o", ms=3, alpha=0.9)
    if best is not None and best.curve:
        ax_curve.plot(*best.curve[-1], marker="*", ms=14, color="k", ls="none", label=f"best trial ({best.trial_id})")
        ax_curve.legend(loc="lower right", fontsize=8)
    ax_curve.set(xlabel="env-steps", ylabel="validation return (g, higher is better)",
                 title="every trial (thick: best configuration, dashed: stopped early)")
    ax_curve.grid(alpha=0.3)
    for y, c in enumerate(shown):
        colour = colours[c.config_id]
        ax_seeds.scatter(c.scores, [y] * len(c.scores), color=colour, s=22, zorder=3)
        ax_seeds.plot([c.iqm, c.iqm], [y - 0.3, y + 0.3], color=colour, lw=3)
        if c.ci_low is not None:
            ax_seeds.plot([c.ci_low, c.ci_high], [y, y], color=colour, lw=1.2)
    seeds = [f"{len(c.scores)} seed{'' if len(c.scores) == 1 else 's'}" for c in shown]
    ax_seeds.set_yticks(range(len(shown)), [f"{c.config_id} ({n})" for c, n in zip(shown, seeds)])
    ax_seeds.set_ylim(len(shown) - 0.4, -0.6)
    ax_seeds.xaxis.set_major_locator(MaxNLocator(4))
    ax_seeds.set(xlabel=f"last {metric} (g)", title="seeds (dots), IQM (bar), 95 % bootstrap CI")
    ax_seeds.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return save_fig(fig, path)
