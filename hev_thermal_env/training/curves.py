"""The figure of a training run: ``DIR/training_curve.png`` (:func:`training_curve_figure`)."""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.ticker import EngFormatter

from hev_thermal_env.evaluation.styles import figure_title, legend_outside, pyplot, save_fig

from .artifacts import read_evaluations
from .config import load_run_config
from .selection import Scorer, get_scorer, run_key

RETURN_TAG, LENGTH_TAG = "rollout/ep_rew_mean", "rollout/ep_len_mean"


def read_training_returns(run_dir: str | Path) -> dict[str, np.ndarray]:
    """``steps``, ``return_g`` and ``length`` of the training episodes logged in ``run_dir/tb`` (empty arrays
    when nothing is logged yet). Later sessions of a resumed run override the steps they repeat."""
    found: dict[str, dict[int, float]] = {RETURN_TAG: {}, LENGTH_TAG: {}}
    files = sorted(Path(run_dir, "tb").rglob("events.out.tfevents.*"), key=lambda p: (p.stat().st_mtime, p.name))
    if files:
        from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

        for f in files:
            acc = EventAccumulator(str(f), size_guidance={"scalars": 0})
            acc.Reload()
            tags = set(acc.Tags().get("scalars", []))
            for tag, series in found.items():
                if tag in tags:
                    series.update({int(e.step): float(e.value) for e in acc.Scalars(tag)})
    steps = sorted(found[RETURN_TAG])
    return {"steps": np.array(steps, dtype=float),
            "return_g": np.array([found[RETURN_TAG][s] for s in steps], dtype=float),
            "length": np.array([found[LENGTH_TAG].get(s, np.nan) for s in steps], dtype=float)}


def selected_step(rows: list[dict[str, Any]]) -> int | None:
    """The env-step of the evaluation whose model is ``best_model.zip``: the last one flagged a new best
    (the lowest selection score when no row is flagged)."""
    if not rows:
        return None
    flagged = [r["timesteps"] for r in rows if r["best"]]
    return int(flagged[-1]) if flagged else int(min(rows, key=lambda r: r["score"])["timesteps"])


def _by_series(rows: list[dict[str, Any]]) -> dict[str, dict[int, dict[str, Any]]]:
    series: dict[str, dict[int, dict[str, Any]]] = {}
    for r in rows:  # a resumed run may evaluate the same step twice: the later row wins
        series.setdefault(run_key(r["cycle"], r["scenario"]), {})[r["timesteps"]] = r
    return series


def training_curve_figure(run_dir: str | Path):
    """The figure of the run in ``run_dir``, three panels over env-steps: the training episodes' mean return and
    length (SB3's ``rollout/ep_rew_mean``, from ``tb/``); the evaluation return per run and their mean; the evaluation
    fuel in % of the selection's reference per run, the score in black, disqualified evaluations crossed,
    ``best_model.zip`` starred. Returns the matplotlib figure."""
    plt = pyplot()
    out = Path(run_dir)
    rows = read_evaluations(out / "evaluations.csv")
    training = read_training_returns(out)
    fig, axes = plt.subplots(3 if rows else 1, 1, figsize=(11, 9.5 if rows else 4.2), sharex=True, squeeze=False,
                             layout="constrained")
    axes = axes[:, 0]
    handles = _training_panel(axes[0], training)
    best = selected_step(rows)
    cfg = load_run_config(out)
    if rows:
        scorer = get_scorer(cfg["eval"]["selection"])
        handles += _return_panel(axes[1], rows) + _selection_panel(axes[2], rows, best, scorer)
        handles += axes[2].plot([], [], color="0.35", ls=":", lw=1.2, label="selected evaluation (all panels)")
        for ax in axes:
            ax.axvline(best, color="0.35", ls=":", lw=1.2, zorder=0)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis="y", useOffset=False)
    axes[-1].set_xlabel("env-steps")
    axes[-1].xaxis.set_major_formatter(EngFormatter(sep=""))
    legend_outside(fig, handles)
    figure_title(fig, f"{str(cfg['algo']).upper()} seed {cfg['seed']}: training return and evaluation on cycles not "
                 f"trained on", fontsize=11)
    return fig


def _training_panel(ax, training: dict[str, np.ndarray]) -> list:
    ax.set_title("training: mean return of the last 100 episodes (raw reward)", fontsize=10)
    ax.set_ylabel("episode return (g)")
    if not len(training["steps"]):
        ax.text(0.5, 0.5, "no training episode has finished yet", transform=ax.transAxes, ha="center",
                va="center", color="0.4")
        return []
    handles = ax.plot(training["steps"], training["return_g"], color="#d62728", lw=1.6,
                      label="training episode return\n(mean of the last 100)")
    twin = ax.twinx()
    handles += twin.plot(training["steps"], training["length"], color="0.6", lw=1.0, ls="--",
                         label="training episode length\n(right axis; random starts)")
    twin.set_ylabel("episode length (steps)", color="0.45")
    twin.set_ylim(bottom=0.0)
    return handles


def _return_panel(ax, rows: list[dict[str, Any]]) -> list:
    """The return of every evaluation run and their mean."""
    handles = []
    for k, by_step in enumerate(_by_series(rows).values()):
        steps = sorted(by_step)
        r = by_step[steps[0]]  # a cycle given as a CSV path is named by its file name
        handles += ax.plot(steps, [by_step[s]["return_g"] for s in steps], color=f"C{k % 10}", lw=1.0, marker=".",
                           label=f"evaluation: {Path(str(r['cycle'])).name} / {r['scenario']}")
    mean = {r["timesteps"]: r["mean_return_g"] for r in rows}
    steps = sorted(mean)
    handles += ax.plot(steps, [mean[s] for s in steps], color="k", lw=2.0, label="mean evaluation return")
    ax.set_title("evaluation return per cycle and their mean", fontsize=10)
    ax.set_ylabel("episode return (g)")
    return handles


def _selection_panel(ax, rows: list[dict[str, Any]], best: int, scorer: Scorer) -> list:
    """Corrected fuel in % of the scorer's reference per run, the score (their mean), disqualified evaluations."""
    ref = scorer.reference_name or "the reference"
    star = textwrap.fill(f"best_model.zip: step {best}, chosen on the {scorer.label}", 42)
    if not all(r["qualified"] for r in rows if r["timesteps"] == best):
        star += "\n(no evaluation qualified: the least penalised)"
    for k, by_step in enumerate(_by_series(rows).values()):
        steps = sorted(by_step)
        ax.plot(steps, [100.0 * by_step[s]["fuel_ratio"] for s in steps], color=f"C{k % 10}", lw=1.0, marker=".")
    by_step: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_step.setdefault(r["timesteps"], []).append(r)
    steps = sorted(by_step)
    score = np.array([100.0 * np.mean([r["fuel_ratio"] for r in by_step[s]]) for s in steps])
    handles = ax.plot(steps, score, color="k", lw=2.0, label=f"selection score: mean fuel in % of {ref}\n"
                                                               f"(lowest selects best_model.zip)")
    bad = [i for i, s in enumerate(steps) if not all(r["qualified"] for r in by_step[s])]
    if bad:
        handles += ax.plot([steps[i] for i in bad], score[bad], ls="none", marker="x", ms=8, mew=2, color="#d62728",
                           zorder=8, label="disqualified: |ΔSOC| over\nthe limit on a run")
    if best in steps:
        handles += ax.plot([best], [score[steps.index(best)]], ls="none", marker="*", ms=16, color="#ffbf00",
                           mec="k", zorder=7, label=star)
    ax.axhline(100.0, color="0.2", lw=0.8)
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, 99.5), max(hi, 100.5))
    ax.set_title(f"evaluation: corrected fuel, % of {ref} on the same run (lower is better; selects the best)",
                 fontsize=10)
    ax.set_ylabel(f"corrected fuel, % of {ref}")
    return handles


def plot_training_curve(run_dir: str | Path) -> Path:
    """Write ``DIR/training_curve.png`` (:func:`training_curve_figure`); returns its path."""
    return save_fig(training_curve_figure(run_dir), Path(run_dir) / "training_curve.png")
