"""Trace figures: every strategy of one cycle and scenario on shared time axes (:func:`plot_run`, drawn alike by the
benchmark and ``evaluate.py run``). Panels, top to bottom: the cycle's speed (thick, light) and each strategy's;
the cumulative missed wheel energy; SOC; motor temperature, with the 70 °C cutoff and its 60 °C release when the
motor comes near them (a mark wherever a motor is cut off); the heat index; the split, one strip per strategy
(colour = motor share u; green: the regeneration share while braking; grey where no torque is demanded).
:func:`plot_benchmark` draws one per cycle and scenario (a seed family as its member nearest the IQM) and the fuel
chart (:mod:`.fuel_chart`).
"""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping
from pathlib import Path

import numpy as np

from hev_thermal_env.envs.render import SPLIT_INFO_KEY
from hev_thermal_env.physics import paper_bus

from .fuel_chart import FUEL_CHART_FILE, plot_fuel_chart
from .styles import CYCLE_COLOUR, figure_title, legend_outside, ordered, pyplot, save_fig, short_label, strategy_styles

__all__ = ["SPLIT_INFO_KEY", "plot_benchmark", "plot_run", "pyplot", "run_figure"]

CUTOFF_COLOUR, RELEASE_COLOUR = "#6a3d9a", "#e08214"

#: The temperature lines are drawn when the hottest motor comes within this of the cutoff's release.
LIMITS_SHOWN_WITHIN_K = 20.0


def _series(trace: Mapping[str, np.ndarray], key: str) -> np.ndarray | None:
    return np.asarray(trace[key], dtype=float) if key in trace else None


def _time(trace: Mapping[str, np.ndarray]) -> np.ndarray:
    return np.asarray(trace["time_s"], dtype=float)


def run_figure(traces: Mapping[str, Mapping[str, np.ndarray]], title: str = "", learned: Collection[str] = ()):
    """The trace figure (module docstring) of ``{label: trace}``, each with per-step ``time_s``, ``speed_mps``,
    ``soc``, ``motor_temp_c``, ``heat_index`` and ``motor_share`` (and, if present, ``cycle_speed_mps``,
    ``missed_wheel_energy_j``, ``motor_cutoff``, ``shaft_torque_demand_nm``); temperature limits of ``paper_bus`` and
    the default reward. ``learned``: more names drawn as learned policies (seed families)."""
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
        handles += ax.plot(_time(cycle), _series(cycle, "cycle_speed_mps") * 3.6, color=CYCLE_COLOUR, lw=5.0,
                           solid_capstyle="butt", zorder=1, label="cycle (demanded speed)")
    for label in labels:
        tr = traces[label]
        handles += ax.plot(_time(tr), _series(tr, "speed_mps") * 3.6, label=short_label(label), **styles[label])
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
