"""The benchmark's figures (docs/benchmark.md): :func:`plot_run`, every strategy of one cycle and scenario on shared
time axes (the benchmark's and ``evaluate.py run``'s), and :data:`FUEL_CHART_FILE` (:func:`fuel_figure`), every
strategy's frontier ratio (1 = the optimum at the run's final SOC; without any frontier, the fixed-price ratio) with
its normalised score, a panel per cycle (column) and scenario (row), a seed family as its IQM (diamond), 95 %
bootstrap interval (whiskers) and seeds (dots). :func:`plot_benchmark` draws both.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping
from pathlib import Path

import numpy as np

from hev_thermal_env.envs.render import SPLIT_INFO_KEY
from hev_thermal_env.physics import paper_bus

from .results_table import OVERALL, ratio_text
from .score import REFERENCE
from .styles import (
    CYCLE_COLOUR,
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

CUTOFF_COLOUR, RELEASE_COLOUR = "#6a3d9a", "#e08214"
#: The temperature lines are drawn when the hottest motor comes within this of the cutoff's release.
LIMITS_SHOWN_WITHIN_K = 20.0


def _series(trace: Mapping[str, np.ndarray], key: str) -> np.ndarray | None:
    return np.asarray(trace[key], dtype=float) if key in trace else None


def _time(trace: Mapping[str, np.ndarray]) -> np.ndarray:
    return np.asarray(trace["time_s"], dtype=float)


def run_figure(traces: Mapping[str, Mapping[str, np.ndarray]], title: str = "", learned: Collection[str] = ()):
    """The trace figure of ``{label: trace}``, each with per-step ``time_s``, ``speed_mps``, ``soc``,
    ``motor_temp_c``, ``heat_index`` and ``motor_share`` (and, if present, ``cycle_speed_mps``,
    ``missed_wheel_energy_j``, ``motor_cutoff``, ``shaft_torque_demand_nm``); temperature limits of ``paper_bus`` and
    the default reward. ``learned``: more names drawn as learned policies (seed families).

    Panels, top to bottom: the cycle's speed (thick, light) and each strategy's; the cumulative missed wheel energy;
    SOC; motor temperature, with the 70 °C cutoff and its 60 °C release when the motor comes near them (a mark
    wherever a motor is cut off); the heat index; the split, one strip per strategy (colour = motor share u; green: the
    regeneration share while braking; grey where no torque is demanded)."""
    if not traces:
        raise ValueError("plot_run: no traces to plot")
    labels = ordered(traces, learned)
    styles = strategy_styles(labels, learned)
    n = len(labels)
    heights = [3.0, 1.5, 1.8, 2.0, 1.4, max(0.32 * n, 0.9)]
    fig, axes = pyplot().subplots(len(heights), 1, figsize=(12.5, 13.0 + 0.25 * n), sharex=True, layout="constrained",
                                  gridspec_kw={"height_ratios": heights})
    ax_v, ax_miss, ax_soc, ax_temp, ax_hi, ax_split = axes
    handles = _speed_panel(ax_v, traces, labels, styles)
    limit_handles = _temperature_panel(ax_temp, traces, labels, styles)
    for label in labels:
        tr, st = traces[label], styles[label]
        t = _time(tr)
        miss = _series(tr, "missed_wheel_energy_j")
        if miss is not None:
            ax_miss.plot(t, np.cumsum(miss) / 3.6e6, **st)
        ax_soc.plot(t, _series(tr, "soc"), **st)
        ax_hi.plot(t, _series(tr, "heat_index"), clip_on=False, **st)
    _split_panel(fig, ax_split, traces, labels, styles)
    ax_miss.set_title("missed wheel energy, cumulative: what the powertrain could not deliver", fontsize=10)
    ax_miss.set(ylabel="missed (kWh)", ylim=(0.0, None))
    ax_soc.set_title("battery state of charge", fontsize=10)
    ax_soc.set_ylabel("SOC (-)")
    ax_hi.set_title("heat index (0: full peak torque available, 1: continuous torque only)", fontsize=10)
    ax_hi.set(ylabel="heat index (-)", ylim=(0.0, 1.0))
    for ax in axes[:-1]:
        ax.grid(alpha=0.3)
    ax_split.set_xlabel("time (s)")
    legend_outside(fig, handles, title="speed and strategies")
    if limit_handles:
        legend_outside(fig, limit_handles, title="motor temperature", loc="outside right lower")
    if title:
        figure_title(fig, title, fontsize=12)
    return fig


def _speed_panel(ax, traces, labels, styles) -> list:
    handles = []
    cycle = next((traces[x] for x in labels if "cycle_speed_mps" in traces[x]), None)
    if cycle is not None:
        handles += ax.plot(_time(cycle), _series(cycle, "cycle_speed_mps") * 3.6, color=CYCLE_COLOUR,
                           lw=5.0, solid_capstyle="butt", zorder=1, label="cycle (demanded speed)")
    for label in labels:
        tr = traces[label]
        handles += ax.plot(_time(tr), _series(tr, "speed_mps") * 3.6, label=short_label(label),
                           **styles[label])
    ax.set_title("speed: the cycle (thick, light) and what each strategy delivered (thin)", fontsize=10)
    ax.set(ylabel="speed (km/h)", ylim=(0.0, None))
    return handles


def _temperature_panel(ax, traces, labels, styles) -> list:
    thermal = paper_bus().thermal
    release_c, cutoff_c = float(thermal.cutoff_release_temp_c), float(thermal.cutoff_temp_c)
    hottest = -np.inf
    for label in labels:
        tr = traces[label]
        t, temp = _time(tr), _series(tr, "motor_temp_c")
        hottest = max(hottest, float(np.nanmax(temp)))
        ax.plot(t, temp, **styles[label])
        cut = _series(tr, "motor_cutoff")
        if cut is not None and cut.any():
            on = cut > 0
            ax.plot(t[on], temp[on], ls="none", marker="|", ms=7, mew=1.2, color=styles[label]["color"], zorder=6)
    handles = []
    if hottest >= release_c - LIMITS_SHOWN_WITHIN_K:
        handles = [ax.axhline(cutoff_c, color=CUTOFF_COLOUR, lw=2.0, ls="-.", label=f"cutoff {cutoff_c:g} °C"),
                   ax.axhline(release_c, color=RELEASE_COLOUR, lw=1.4, ls=":",
                              label=f"release {release_c:g} °C\n(a cut-off motor runs again)"),
                   *ax.plot([], [], ls="none", marker="|", ms=7, mew=1.2, color="0.3",
                            label="motor cut off\n(mark on its line)")]
        ax.set_ylim(top=cutoff_c + 4.0)
        ax.set_title("motor temperature", fontsize=10)
    else:
        ax.set_title(f"motor temperature (peak {hottest:.1f} °C: far below the {cutoff_c:g} °C cutoff and its "
                     f"{release_c:g} °C release, not drawn)", fontsize=10)
    ax.set_ylabel("motor (°C)")
    return handles


def _split_panel(fig, ax, traces, labels, styles) -> None:
    """One strip per strategy: u in colour while the shaft pulls, the regeneration share u (0-1) in green while it
    brakes, grey where no torque is demanded."""
    from matplotlib.colors import ListedColormap

    t_all = [_time(traces[label]) for label in labels]
    t0, t1 = min(float(t[0]) for t in t_all), max(float(t[-1]) for t in t_all)
    n_cols = int(round(t1 - t0)) + 1
    grid = np.full((len(labels), n_cols), np.nan)
    regen = np.full((len(labels), n_cols), np.nan)
    idle = np.zeros((len(labels), n_cols))
    for i, (label, t) in enumerate(zip(labels, t_all)):
        tr = traces[label]
        col = np.clip(np.round(t - t0).astype(int), 0, n_cols - 1)
        u = _series(tr, SPLIT_INFO_KEY)
        grid[i, col] = u
        demand = _series(tr, "shaft_torque_demand_nm")
        if demand is not None:
            braking, standing = demand < 0.0, demand == 0.0
            grid[i, col[demand <= 0.0]] = np.nan
            regen[i, col[braking]] = np.clip(u[braking], 0.0, 1.0)
            idle[i, col[standing]] = 1.0
    extent = (t0 - 0.5, t1 + 0.5, len(labels) - 0.5, -0.5)
    ax.imshow(np.where(idle > 0, 1.0, np.nan), aspect="auto", extent=extent, interpolation="nearest",
              cmap=ListedColormap(["#e0e0e0"]), vmin=0, vmax=1)
    ax.imshow(regen, aspect="auto", extent=extent, interpolation="nearest", cmap="Greens", vmin=-0.15, vmax=1.0)
    img = ax.imshow(grid, aspect="auto", extent=extent, interpolation="nearest", cmap="RdBu_r", vmin=-1.0, vmax=1.0)
    ax.set_yticks(range(len(labels)), [short_label(x) for x in labels], fontsize=8)
    for tick, label in zip(ax.get_yticklabels(), labels):
        tick.set_color(styles[label]["color"])
    ax.set_title("torque split u (red: motor assists, blue: engine charges; braking: green = share of regeneration "
                 "taken; grey: no torque)", fontsize=10)
    cbar = fig.colorbar(img, ax=ax, fraction=0.03, pad=0.01, ticks=[-1, 0, 1])
    cbar.ax.set_yticklabels(["-1 charge", "0", "+1 motor"], fontsize=7)


def plot_run(traces: Mapping[str, Mapping[str, np.ndarray]], path: str | os.PathLike, title: str = "",
             learned: Collection[str] = ()) -> Path:
    """Draw one or more runs (``{label: trace}``) into a PNG at ``path`` (see :func:`run_figure`); returns the path."""
    return save_fig(run_figure(traces, title, learned), path)


FUEL_CHART_FILE = "fuel_vs_optimum.png"
LEARNED_GAP = 0.8  # extra rows of space between the classic strategies and the learned policies
SEED_SPREAD = 0.32  # vertical spread of a family's seed dots (rows are 1 apart)
MAX_PANEL_COLUMNS = 4  # more cycles than this wrap onto further rows of panels

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
    # a row of panels per scenario, a column per cycle; more cycles than MAX_PANEL_COLUMNS wrap onto further rows
    n_cols = min(len(cycles), MAX_PANEL_COLUMNS)
    rows_per_scenario = -(-len(cycles) // n_cols)
    fig, axes = pyplot().subplots(len(scenarios) * rows_per_scenario, n_cols, sharex=True, sharey=True,
                                  squeeze=False, layout="constrained",
                                  figsize=(4.8 * n_cols + 2.4, height * len(scenarios) * rows_per_scenario + 1.2))
    axes[0, 0].set_xlim(*_value_range(values or [1.0], bool(families)))  # shared: before the labels
    for i, sc in enumerate(scenarios):
        for j in range(rows_per_scenario * n_cols):
            ax = axes[i * rows_per_scenario + j // n_cols, j % n_cols]
            if j >= len(cycles):
                ax.set_visible(False)
                axes[i * rows_per_scenario + j // n_cols - 1, j % n_cols].xaxis.set_tick_params(labelbottom=True)
                continue
            cyc = cycles[j]
            sel = {r["strategy"]: r for r in drawn if r["cycle"] == cyc and r["scenario"] == sc}
            seeds = {f: [m for m in ms if m["cycle"] == cyc and m["scenario"] == sc] for f, ms in members.items()}
            _panel(ax, sel, seeds, key, pos, styles, families)
            ax.set_title(f"{cyc} cycle, {sc} scenario", fontsize=10)
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
        return f"{name} ({len({m['strategy'] for m in members.get(name, [])})} seeds)"
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
        colour, learned_row = styles[name]["color"], is_learned(name, families)
        if r.get(key) is None:
            why = "final SOC off the frontier" if "outside" in str(r.get("frontier_note")) else "see results.md"
            ax.annotate(f"n/a ({why})", (origin, y), xytext=(5, 0), textcoords="offset points", va="center",
                        fontsize=7.5, color="0.45", style="italic")
            continue
        v = float(r[key])
        if name in families:
            left, right = _family(ax, r, seeds.get(name, []), key, y, colour)
        else:
            ax.plot([origin, v], [y, y], color=colour, lw=2.2 if learned_row else 1.4, zorder=2,
                    solid_capstyle="butt")
            ax.plot([v], [y], marker="D" if learned_row else "o", ms=7 if learned_row else 6, color=colour, zorder=3)
            left = right = v
        # a value clearly below the reference is labelled on its left, away from the line; others (and a family's
        # longer label, with its interval) on the right, past the reference line if need be
        lo, hi = ax.get_xlim()
        below = right < origin - 0.08 * (hi - lo) and name not in families
        right = max(right, origin)
        ax.annotate(_value_label(r, key), (left if below else right, y), xytext=(-7 if below else 7, 0),
                    textcoords="offset points", va="center", ha="right" if below else "left", fontsize=8,
                    fontweight="bold" if learned_row else "normal")
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
    ax.plot(xs, [y + SEED_SPREAD * ((i + 0.5) / n - 0.5) for i in range(n)], ls="none", marker="o", ms=3.5,
            color=colour, alpha=0.6, zorder=3)
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


def plot_benchmark(out: Path, rows: list[dict], traces: dict, cycles: list[str] | None = None,
                   scenarios: list[str] | None = None) -> None:
    """``out/traces_<cycle>_<scenario>.png`` and ``out/fuel_vs_optimum.png``; ``traces`` maps (cycle, scenario,
    strategy) to a run's trace. Cycles and scenarios in the order given (default: as they first appear in the rows)."""
    runs = [r for r in rows if r.get("family") is None]
    cycles = list(dict.fromkeys(cycles or [r["cycle"] for r in runs]))
    scenarios = list(dict.fromkeys(scenarios or [r["scenario"] for r in runs]))
    families = {r["family"] for r in rows if r.get("family") is not None}
    for cyc in cycles:
        for sc in scenarios:
            group = {st: tr for (c, s, st), tr in traces.items() if c == cyc and s == sc}
            if group:
                plot_run(group, out / f"traces_{cyc}_{sc}.png", title=f"{cyc} cycle, {sc} scenario: every strategy",
                         learned=families)
    plot_fuel_chart(rows, out / FUEL_CHART_FILE, cycles, scenarios)
