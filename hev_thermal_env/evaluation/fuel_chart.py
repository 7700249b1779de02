"""``fuel_vs_dp.png``: corrected fuel of every strategy relative to DP, one panel per cycle and scenario.

A dot chart that stays readable as the benchmark grows: one row of panels per scenario, one
column per cycle (both in the benchmark's order), the strategies from the simplest (top) to the
optimum, and the learned policies below a gap on a shaded band. Every panel shares one x axis,
which always includes 100 % (the DP optimum), so a dot's distance from the 100 % line reads the
same everywhere; each dot carries its value. Without DP in the benchmark the chart shows the
corrected fuel in L/100 km on an axis from 0.
"""

from __future__ import annotations

from pathlib import Path

from hev_thermal_env.io import save_png

from .styles import (
    LEARNED_BAND_COLOUR,
    close,
    figure_title,
    is_learned,
    legend_outside,
    ordered,
    pyplot,
    short_label,
    strategy_styles,
)

LEARNED_GAP = 0.8  # extra rows of space between the classic strategies and the learned policies


def _positions(strategies: list[str]) -> dict[str, float]:
    pos, y = {}, 0.0
    for i, name in enumerate(strategies):
        if i and is_learned(name) and not is_learned(strategies[i - 1]):
            y += LEARNED_GAP
        pos[name] = y
        y += 1.0
    return pos


def _value_range(values: list[float], ratio: bool) -> tuple[float, float]:
    """One x range for every panel: from 100 % (or 0 L/100 km) to the largest value, with room for labels."""
    lo, hi = (min(min(values), 100.0), max(max(values), 100.0)) if ratio else (0.0, max(values))
    span = max(hi - lo, 1.0)
    return (lo - (0.12 if lo < 100.0 else 0.03) * span if ratio else 0.0), hi + 0.16 * span


def fuel_figure(rows: list[dict], cycles: list[str] | None = None, scenarios: list[str] | None = None):
    """The chart of ``rows`` (benchmark rows with ``cycle``, ``scenario``, ``strategy``, ``fuel_vs_dp_pct``,
    ``fuel_corrected_l_per_100km``); returns the matplotlib figure."""
    if not rows:
        raise ValueError("fuel chart: no benchmark rows")
    plt = pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import PercentFormatter

    cycles = list(dict.fromkeys(cycles or [r["cycle"] for r in rows]))
    scenarios = list(dict.fromkeys(scenarios or [r["scenario"] for r in rows]))
    ratio = any(r.get("fuel_vs_dp_pct") for r in rows)
    key = "fuel_vs_dp_pct" if ratio else "fuel_corrected_l_per_100km"
    strategies = ordered(r["strategy"] for r in rows)
    styles = strategy_styles(strategies)
    pos = _positions(strategies)
    values = [float(r[key]) for r in rows if r.get(key) is not None]
    xlim = _value_range(values, ratio)
    height = 0.27 * (max(pos.values()) + 1.0) + 1.1
    fig, axes = plt.subplots(len(scenarios), len(cycles), sharex=True, sharey=True, squeeze=False,
                             figsize=(4.8 * len(cycles) + 2.4, height * len(scenarios) + 1.2), layout="constrained")
    for i, sc in enumerate(scenarios):
        for j, cyc in enumerate(cycles):
            sel = {r["strategy"]: r for r in rows if r["cycle"] == cyc and r["scenario"] == sc}
            _panel(axes[i, j], sel, key, pos, styles, ratio)
            axes[i, j].set_title(f"{cyc} cycle, {sc} scenario", fontsize=10)
    ax0 = axes[0, 0]
    ax0.set_xlim(*xlim)
    if ratio:
        ax0.xaxis.set_major_formatter(PercentFormatter(decimals=0))
    ax0.set_ylim(max(pos.values()) + 0.7, -0.7)
    ax0.set_yticks(list(pos.values()))
    for ax in axes[:, 0]:
        ax.set_yticklabels([short_label(s) for s in pos], fontsize=9)
        for tick, name in zip(ax.get_yticklabels(), pos):
            tick.set_color(styles[name]["color"])
            tick.set_fontweight("bold" if is_learned(name) else "normal")
    xlabel = ("corrected fuel, % of DP on the same cycle and scenario (lower is better; 100 % = optimum)" if ratio
              else "corrected fuel (L/100 km, lower is better; no DP in this benchmark)")
    fig.supxlabel(xlabel, fontsize=10)
    handles = [Line2D([], [], color="k", lw=1.0, label="DP optimum = 100 %" if ratio else "0 L/100 km"),
               Line2D([], [], color="0.4", marker="o", ls="-", lw=1.0, label="classic strategy"),
               Line2D([], [], color=styles[strategies[-1]]["color"] if is_learned(strategies[-1]) else "0.4",
                      marker="D", ls="none", label="learned policy"),
               Patch(facecolor=LEARNED_BAND_COLOUR, label="learned policies (set apart)")]
    legend_outside(fig, handles, [h.get_label() for h in handles])
    figure_title(fig, "Corrected fuel relative to the dynamic-programming optimum" if ratio else "Corrected fuel",
                 fontsize=12)
    return fig


def _panel(ax, sel: dict[str, dict], key: str, pos: dict[str, float], styles: dict, ratio: bool) -> None:
    base = 100.0 if ratio else 0.0
    learned = [p for s, p in pos.items() if is_learned(s)]
    if learned:
        ax.axhspan(min(learned) - 0.5, max(learned) + 0.5, color=LEARNED_BAND_COLOUR, zorder=0, lw=0)
    ax.axvline(base, color="k", lw=1.0, zorder=1)
    for name, y in pos.items():
        r = sel.get(name)
        if r is None or r.get(key) is None:
            continue
        v = float(r[key])
        colour = styles[name]["color"]
        ax.plot([base, v], [y, y], color=colour, lw=2.2 if is_learned(name) else 1.4, zorder=2,
                solid_capstyle="butt")
        ax.plot([v], [y], marker="D" if is_learned(name) else "o", ms=7 if is_learned(name) else 6, color=colour,
                zorder=3)
        below = v < base  # a value below the reference is labelled on its left, away from the line
        ax.annotate(f"{v:.1f} %" if ratio else f"{v:.2f}", (v, y), xytext=(-7 if below else 7, 0),
                    textcoords="offset points", va="center", ha="right" if below else "left", fontsize=8,
                    fontweight="bold" if is_learned(name) else "normal")
    ax.grid(axis="x", alpha=0.3)
    ax.tick_params(axis="y", length=0)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)


def plot_fuel_vs_dp(rows: list[dict], path: Path, cycles: list[str] | None = None,
                    scenarios: list[str] | None = None) -> Path:
    """Write :func:`fuel_figure` of ``rows`` to ``path``; returns the path."""
    fig = fuel_figure(rows, cycles, scenarios)
    try:
        return save_png(fig, path)
    finally:
        close(fig)
