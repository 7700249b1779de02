"""``sweep.png``: validation curves of every trial, and the seed spread of the best configurations."""

from __future__ import annotations

from pathlib import Path

from matplotlib.ticker import MaxNLocator

from hev_thermal_env.evaluation.plots import pyplot
from hev_thermal_env.io import save_png

from .sweep_trial import METRIC

#: Configurations shown in the right panel (best first).
MAX_CONFIGS_SHOWN = 12


def plot_sweep(trials, configs, best, path: Path) -> Path:
    """``path`` (a PNG). Left: validation return over env-steps per trial (the best configuration drawn
    thick, trials stopped early dashed). Right: per configuration, each seed's last return (dots), the
    IQM (bar) and its 95 % bootstrap interval (whiskers)."""
    plt = pyplot()
    shown = [c for c in configs if c.iqm is not None][:MAX_CONFIGS_SHOWN]
    colours = {c.config_id: plt.cm.tab10(i % 10) for i, c in enumerate(shown)}
    fig, (ax_curve, ax_seeds) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    best_config = best.config_id if best is not None else None
    for t in trials:
        if not t.curve:
            continue
        steps, values = zip(*t.curve)
        ax_curve.plot(steps, values, color=colours.get(t.config_id, "0.7"),
                      lw=2.4 if t.config_id == best_config else 1.0, ls="--" if t.status == "stopped" else "-",
                      marker="o", ms=3, alpha=0.9)
    if best is not None and best.curve:
        ax_curve.plot(*best.curve[-1], marker="*", ms=14, color="k", ls="none", label=f"best trial ({best.trial_id})")
        ax_curve.legend(loc="lower right", fontsize=8)
    ax_curve.set_xlabel("env-steps")
    ax_curve.set_ylabel("validation return (g, higher is better)")
    ax_curve.set_title("every trial (thick: best configuration, dashed: stopped early)")
    ax_curve.grid(alpha=0.3)
    for y, c in enumerate(shown):
        colour = colours[c.config_id]
        ax_seeds.scatter(c.scores, [y] * len(c.scores), color=colour, s=22, zorder=3)
        ax_seeds.plot([c.iqm, c.iqm], [y - 0.3, y + 0.3], color=colour, lw=3)
        if c.ci_low is not None:
            ax_seeds.plot([c.ci_low, c.ci_high], [y, y], color=colour, lw=1.2)
    ax_seeds.set_yticks(range(len(shown)), [f"{c.config_id} ({len(c.scores)} seeds)" for c in shown])
    ax_seeds.set_ylim(len(shown) - 0.4, -0.6)
    ax_seeds.xaxis.set_major_locator(MaxNLocator(4))
    ax_seeds.set_xlabel(f"last {METRIC} (g)")
    ax_seeds.set_title("seeds (dots), IQM (bar), 95 % bootstrap CI")
    ax_seeds.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)
    return path
