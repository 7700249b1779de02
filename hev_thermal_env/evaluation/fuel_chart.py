"""``fuel_vs_optimum.png``: every strategy against the thermal optimum, a panel per cycle (column) and scenario (row).

Rows go from the simplest strategy (top) to the optimum, the learned policies below a gap on a shaded band. The
shared x axis is the frontier ratio (:mod:`.yardstick`; 1 = the optimum at the run's final SOC) and always holds 1;
each dot carries its value and the normalised score (:mod:`.score`: 0 = ``engine_only``, 100 = the optimum). A seed
family (:mod:`.families`) is one row: IQM (diamond), 95 % bootstrap interval (whiskers), each seed (small dots). A run
without a ratio is marked "n/a"; without any frontier the chart shows the fixed-price ratio (corrected fuel over
``dp_thermal``'s).
"""

from __future__ import annotations

from pathlib import Path

from .families import OVERALL
from .results_table import ratio_text
from .styles import (
    LEARNED_BAND_COLOUR,
    figure_title,
    is_learned,
    legend_outside,
    ordered,
    pyplot,
    save_fig,
    short_label,
    strategy_styles,
)
from .yardstick import REFERENCE

FUEL_CHART_FILE = "fuel_vs_optimum.png"
LEARNED_GAP = 0.8  # extra rows of space between the classic strategies and the learned policies
SEED_SPREAD = 0.32  # vertical spread of a family's seed dots (rows are 1 apart)

#: What the x axis shows, in order of preference: (row key, axis label, title, 1 line's legend label).
MEASURES = (
    ("frontier_ratio", "frontier ratio: cost / the thermal optimum's cost at the same final SOC (lower is better)",
     "Every strategy against the thermal optimum (1 = the optimum at the run's final SOC)",
     "thermal optimum = 1"),
    ("fixed_price_ratio", f"fixed-price ratio: corrected fuel / {REFERENCE}'s (lower is better; no frontier)",
     f"Corrected fuel relative to {REFERENCE} (fixed battery price)", f"{REFERENCE} = 1"),
)


def _positions(strategies: list[str], learned: set[str]) -> dict[str, float]:
    pos, y = {}, 0.0
    for i, name in enumerate(strategies):
        if i and is_learned(name, learned) and not is_learned(strategies[i - 1], learned):
            y += LEARNED_GAP
        pos[name] = y
        y += 1.0
    return pos


def _value_range(values: list[float], wide_right: bool = False) -> tuple[float, float]:
    """One x range for every panel: from the reference 1 to the largest value, room for labels (more on the right
    with ``wide_right``: a family's label carries its interval)."""
    right = 0.38 if wide_right else 0.16
    lo, hi = min(min(values), 1.0), max(max(values), 1.0)
    span = max(hi - lo, 0.01)
    return lo - (0.12 if lo < 1.0 else 0.03) * span, hi + right * span


def _split(rows: list[dict]) -> tuple[list[dict], dict[str, list[dict]]]:
    """(rows drawn as rows: runs and per-panel family rows, {family: its members' rows})."""
    drawn = [r for r in rows if r.get("family") is None or (r["strategy"] == r["family"] and r["cycle"] != OVERALL)]
    members: dict[str, list[dict]] = {}
    for r in rows:
        if r.get("family") not in (None, r["strategy"]):
            members.setdefault(r["family"], []).append(r)
    return drawn, members


def fuel_figure(rows: list[dict], cycles: list[str] | None = None, scenarios: list[str] | None = None):
    """The chart of benchmark ``rows`` (``cycle``, ``scenario``, ``strategy``, the ratios; family rows with ``family``
    and the ``_ci_low``/``_ci_high`` columns); returns the matplotlib figure."""
    drawn, members = _split(rows)
    if not drawn:
        raise ValueError("fuel chart: no benchmark rows")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cycles = list(dict.fromkeys(cycles or [r["cycle"] for r in drawn]))
    scenarios = list(dict.fromkeys(scenarios or [r["scenario"] for r in drawn]))
    key, xlabel, title, base_label = next((m for m in MEASURES if any(r.get(m[0]) is not None for r in drawn)),
                                          MEASURES[-1])
    families = set(members) | {r["family"] for r in drawn if r.get("family")}
    strategies = ordered((r["strategy"] for r in drawn), families)
    styles = strategy_styles(strategies, families)
    pos = _positions(strategies, families)
    values = [float(r[k]) for r in drawn for k in (key, f"{key}_ci_low", f"{key}_ci_high") if r.get(k) is not None]
    values += [float(m[key]) for ms in members.values() for m in ms if m.get(key) is not None]
    height = 0.27 * (max(pos.values()) + 1.0) + 1.1
    fig, axes = pyplot().subplots(len(scenarios), len(cycles), sharex=True, sharey=True, squeeze=False,
                                  figsize=(4.8 * len(cycles) + 2.4, height * len(scenarios) + 1.2),
                                  layout="constrained")
    axes[0, 0].set_xlim(*_value_range(values or [1.0], bool(families)))  # shared: before the labels
    for i, sc in enumerate(scenarios):
        for j, cyc in enumerate(cycles):
            sel = {r["strategy"]: r for r in drawn if r["cycle"] == cyc and r["scenario"] == sc}
            seeds = {f: [m for m in ms if m["cycle"] == cyc and m["scenario"] == sc] for f, ms in members.items()}
            _panel(axes[i, j], sel, seeds, key, pos, styles, families)
            axes[i, j].set_title(f"{cyc} cycle, {sc} scenario", fontsize=10)
    ax0 = axes[0, 0]
    ax0.ticklabel_format(axis="x", useOffset=False, style="plain")
    ax0.set(ylim=(max(pos.values()) + 0.7, -0.7), yticks=list(pos.values()))
    for ax in axes[:, 0]:
        ax.set_yticklabels([_row_label(s, families, members) for s in pos], fontsize=9)
        for tick, name in zip(ax.get_yticklabels(), pos):
            tick.set_color(styles[name]["color"])
            tick.set_fontweight("bold" if is_learned(name, families) else "normal")
    fig.supxlabel(xlabel + _reference_line(drawn, key), fontsize=10)
    handles = [Line2D([], [], color="k", lw=1.0, label=base_label),
               Line2D([], [], color="0.4", marker="o", ls="-", lw=1.0, label="classic strategy")]
    if any(is_learned(s, families) and s not in families for s in strategies):
        handles.append(Line2D([], [], color="0.4", marker="D", ls="none", label="learned policy"))
    if families:
        handles += [Line2D([], [], color="0.4", marker="D", ms=7, ls="-", lw=2.0,
                           label="seed family: IQM (diamond),\n95 % bootstrap CI (whiskers)"),
                    Line2D([], [], color="0.4", marker="o", ms=3.5, ls="none", alpha=0.6, label="one seed")]
    if any(is_learned(s, families) for s in strategies):
        handles.append(Patch(facecolor=LEARNED_BAND_COLOUR, label="learned policies (set apart)"))
    legend_outside(fig, handles)
    figure_title(fig, title, fontsize=12)
    return fig


def _row_label(name: str, families: set[str], members: dict[str, list[dict]]) -> str:
    if name in families:
        n = len({m["strategy"] for m in members.get(name, [])})
        return f"{name} ({n} seeds)"
    return short_label(name)


def _reference_line(rows: list[dict], key: str) -> str:
    """A second x-label line naming the reference, when the ratio has one reference everywhere."""
    refs = {r.get("reference") for r in rows if r.get("reference")}
    if len(refs) != 1:
        return ""
    ref = refs.pop()
    return "\n1 = " + (ref if len(ref) <= 110 else ref[:109] + "…")


def _panel(ax, sel: dict[str, dict], seeds: dict[str, list[dict]], key: str, pos: dict[str, float], styles: dict,
           families: set[str]) -> None:
    origin = 1.0
    learned = [p for s, p in pos.items() if is_learned(s, families)]
    if learned:
        ax.axhspan(min(learned) - 0.5, max(learned) + 0.5, color=LEARNED_BAND_COLOUR, zorder=0, lw=0)
    ax.axvline(origin, color="k", lw=1.0, zorder=1)
    for name, y in pos.items():
        r = sel.get(name)
        if r is None:
            continue
        colour = styles[name]["color"]
        if r.get(key) is None:
            why = "final SOC off the frontier" if "outside" in str(r.get("frontier_note")) else "see results.md"
            ax.annotate(f"n/a ({why})", (origin, y), xytext=(5, 0), textcoords="offset points", va="center",
                        fontsize=7.5, color="0.45", style="italic")
            continue
        v = float(r[key])
        if name in families:
            left, right = _family(ax, r, seeds.get(name, []), key, y, colour)
        else:
            ax.plot([origin, v], [y, y], color=colour, lw=2.2 if is_learned(name, families) else 1.4, zorder=2,
                    solid_capstyle="butt")
            ax.plot([v], [y], marker="D" if is_learned(name, families) else "o",
                    ms=7 if is_learned(name, families) else 6, color=colour, zorder=3)
            left = right = v
        # a value clearly below the reference is labelled on its left, away from the line; others (and a family's
        # longer label, with its interval) on the right, past the reference line if need be
        lo, hi = ax.get_xlim()
        below = right < origin - 0.08 * (hi - lo) and name not in families
        right = max(right, origin)
        ax.annotate(_value_label(r, key), (left if below else right, y), xytext=(-7 if below else 7, 0),
                    textcoords="offset points", va="center", ha="right" if below else "left", fontsize=8,
                    fontweight="bold" if is_learned(name, families) else "normal")
    ax.grid(axis="x", alpha=0.3)
    ax.tick_params(axis="y", length=0)
    ax.spines[["top", "right"]].set_visible(False)


def _value_label(r: dict, key: str) -> str:
    """The ratio's text; beside the frontier ratio, the normalised score (:mod:`.score`) where the row has one."""
    text = ratio_text(r, key)
    if key == "frontier_ratio" and r.get("score") is not None:
        text += f"  · score {r['score']:.0f}" + (" (ill-cond.)" if r.get("score_note") else "")
    return text


def _family(ax, r: dict, seeds: list[dict], key: str, y: float, colour: str) -> tuple[float, float]:
    """Draw a family's seeds, interval and IQM on row ``y``; returns its left and right ends (for the label)."""
    xs = [float(m[key]) for m in seeds if m.get(key) is not None]
    n = len(xs)
    offsets = [SEED_SPREAD * ((i + 0.5) / n - 0.5) for i in range(n)]
    ax.plot(xs, [y + o for o in offsets], ls="none", marker="o", ms=3.5, color=colour, alpha=0.6, zorder=3)
    v, low, high = float(r[key]), r.get(f"{key}_ci_low"), r.get(f"{key}_ci_high")
    if low is not None and high is not None:
        ax.errorbar([v], [y], xerr=[[v - float(low)], [float(high) - v]], fmt="none", ecolor=colour, elinewidth=2.0,
                    capsize=4, capthick=1.6, zorder=4)
    ax.plot([v], [y], marker="D", ms=7.5, color=colour, markeredgecolor="white", markeredgewidth=0.8, zorder=5)
    ends = [v, *xs, *(float(e) for e in (low, high) if e is not None)]
    return min(ends), max(ends)


def plot_fuel_chart(rows: list[dict], path: Path, cycles: list[str] | None = None,
                    scenarios: list[str] | None = None) -> Path:
    """Write :func:`fuel_figure` of ``rows`` to ``path``; returns the path."""
    return save_fig(fuel_figure(rows, cycles, scenarios), path)
