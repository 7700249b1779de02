"""``DIR/training_curve.png``: the evaluation during training, against timesteps."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hev_thermal_env.evaluation.plots import pyplot
from hev_thermal_env.io import save_png

from .artifacts import read_evaluations
from .config import load_run_config


def plot_training_curve(run_dir: str | Path, dp_reference: dict[str, float] | None = None) -> Path:
    """``DIR/training_curve.png``: per evaluation cycle and scenario, the episode return (training
    reward) and the corrected fuel (with DP's as a dashed line when known) against timesteps."""
    plt = pyplot()
    out = Path(run_dir)
    rows = read_evaluations(out / "evaluations.csv")
    series: dict[str, dict[int, dict[str, Any]]] = {}
    for r in rows:  # a resumed run may evaluate the same step twice: the later row wins
        series.setdefault(f"{r['cycle']} / {r['scenario']}", {})[r["timesteps"]] = r
    n = max(len(series), 1)
    fig, axes = plt.subplots(2, n, figsize=(4.2 * n, 6), sharex=True, squeeze=False)
    for j, (label, by_step) in enumerate(series.items()):
        steps = sorted(by_step)
        best = [s for s in steps if by_step[s]["best"]]
        axes[0, j].plot(steps, [by_step[s]["return_g"] for s in steps], marker=".")
        axes[0, j].set_title(label, fontsize=10)
        axes[1, j].plot(steps, [by_step[s]["fuel_corrected_l_per_100km"] for s in steps], marker=".", label="policy")
        axes[1, j].plot(best, [by_step[s]["fuel_corrected_l_per_100km"] for s in best], "o", mfc="none", ms=8,
                        label="new best (mean return)")
        if dp_reference and label in dp_reference:
            axes[1, j].axhline(dp_reference[label], color="k", ls="--", lw=1, label="DP")
        axes[1, j].set_xlabel("timesteps")
        axes[1, j].legend(fontsize=8)
    axes[0, 0].set_ylabel("episode return (training reward, g)")
    axes[1, 0].set_ylabel("corrected fuel (L/100 km)")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    cfg = load_run_config(out)
    fig.suptitle(f"{cfg['algo'].upper()} seed {cfg['seed']}: deterministic evaluation on cycles not trained on",
                 fontsize=10)
    fig.tight_layout()
    path = save_png(fig, out / "training_curve.png")
    plt.close(fig)
    return path
