"""The paper report's figures, with the paper's own points and tolerance bands drawn on them: ``verdicts.png`` (each
judged figure's distance from the paper in tolerances), ``fig4_heat_index.png``, ``thermal_time_to_cutoff.png``
(coolant off at peak power, against the heat-balance estimate), ``fig_temperature_heat_index_<cycle>.png`` (Figs
7-10) and ``fig_table2_fuel.png`` (absolute fuel levels: ours, raw and corrected, and the paper's Table 2).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.evaluation.styles import figure_title, legend_outside, pyplot, save_fig

from .figures import PAPER_FIGURE_BY_NAME as FIGURES

PAPER_COLOUR, OURS_COLOUR, OFF_COLOUR = "#e66101", "#1f78b4", "#999999"
WITHIN_COLOUR, OUTSIDE_COLOUR, BAND_COLOUR = "#1a9641", "#d7191c", "#fdb863"
RESIDUAL_SHOWN = 4.0  # verdict chart: residuals beyond ± this are drawn at the edge with their value


def _legend(fig, *axes) -> None:
    legend_outside(fig, [h for ax in axes for h in ax.get_legend_handles_labels()[0]])


def _value_text(r: dict[str, Any]) -> str:
    unit = "" if r["unit"] == "-" else f" {r['unit']}"
    ours = "not observed" if r["ours"] is None else f"{r['ours']:.3g}{unit}"
    tol = r["tolerance"]
    paper = (f"{r['paper']:g}{unit}, limit {tol}" if tol.startswith("≤") else
             f"{r['paper']:g}{unit} {tol}" if tol.endswith("%") else f"{r['paper']:g} {tol}")
    return f"ours {ours}  |  paper {paper}"


def verdict_figure(rows: list[dict[str, Any]], path: Path) -> Path:
    """Each judged figure as (ours − paper) / tolerance: inside the shaded band [−1, 1] means agreement."""
    from matplotlib.lines import Line2D

    fig, ax = pyplot().subplots(figsize=(13.5, 0.3 * len(rows) + 1.7), layout="constrained")
    ax.axvspan(-1.0, 1.0, color=WITHIN_COLOUR, alpha=0.12, lw=0)
    ax.axvline(0.0, color="k", lw=1.0)
    for i, r in enumerate(rows):
        colour = WITHIN_COLOUR if r["within"] else OUTSIDE_COLOUR
        if i and r["figure"] != rows[i - 1]["figure"]:
            ax.axhline(i - 0.5, color="0.6", lw=0.8)
        ax.annotate(_value_text(r), (1.0, i), xycoords=("axes fraction", "data"), xytext=(8, 0),
                    textcoords="offset points", va="center", fontsize=8, color=colour)
        if r["residual"] is None:
            ax.text(0.0, i, "  no value", va="center", fontsize=8, color=OUTSIDE_COLOUR)
            continue
        x = float(np.clip(r["residual"], -RESIDUAL_SHOWN, RESIDUAL_SHOWN))
        clipped = abs(r["residual"]) > RESIDUAL_SHOWN
        ax.plot([x], [i], marker=(">" if x > 0 else "<") if clipped else "o", ms=8, color=colour, ls="none")
        if clipped:
            ax.annotate(f"{r['residual']:+.1f}", (x, i), xytext=(-8 if x > 0 else 8, 0), textcoords="offset points",
                        fontsize=7.5, ha="right" if x > 0 else "left", va="center", color=colour)
    ax.set(yticks=range(len(rows)), ylim=(len(rows) - 0.5, -0.5), xlim=(-RESIDUAL_SHOWN - 0.3, RESIDUAL_SHOWN + 0.3),
           xlabel="(ours − paper) / tolerance   (for an upper limit: ours / limit)")
    ax.set_yticklabels([f"{r['id']} {r['figure']}: {r['description']}" for r in rows], fontsize=8.5)
    ax.grid(axis="x", alpha=0.3)
    handles = [Line2D([], [], marker="o", ls="none", color=WITHIN_COLOUR, label="within tolerance (shaded band)"),
               Line2D([], [], marker="o", ls="none", color=OUTSIDE_COLOUR, label="outside tolerance"),
               Line2D([], [], marker="<", ls="none", color=OUTSIDE_COLOUR,
                      label=f"beyond ±{RESIDUAL_SHOWN:g}: drawn at the edge, value beside it")]
    legend_outside(fig, handles, ncol=3, loc="outside lower center")
    figure_title(fig, f"Paper figures: {sum(r['within'] for r in rows)} of {len(rows)} within tolerance", fontsize=11)
    return save_fig(fig, path)


def fig4_figure(curve: dict[str, Any], path: Path) -> Path:
    fig, ax = pyplot().subplots(figsize=(9, 3.8), layout="constrained")
    ax.plot(curve["time_s"], curve["pwm"], color=OURS_COLOUR, label="ours: heat index PWM")
    ax.plot([FIGURES["fig4_leaves_zero_s"].paper, FIGURES["fig4_reaches_one_s"].paper], [0.0, 1.0], ls="none",
            marker="D", ms=8, mfc="none", mec=PAPER_COLOUR, mew=1.8,
            label="paper Fig. 4: leaves 0 at 30 s,\nreaches 1 at 130 s")
    ax.set(xlabel="time (s)", ylabel="heat index PWM (-)", ylim=(0.0, 1.05))
    ax2 = ax.twinx()
    ax2.plot(curve["time_s"], curve["torque_nm"], color="#6a3d9a", ls="--", label="ours: available torque (right)")
    ax2.set(ylabel="available torque (N·m)", ylim=(0.0, None))
    ax.grid(alpha=0.3)
    ax.set_title("Fig. 4 analog: heat index at 2× the continuous torque, from cold", fontsize=10)
    _legend(fig, ax, ax2)
    return save_fig(fig, path)


def cutoff_figure(curve: dict[str, Any], path: Path) -> Path:
    fig, ax = pyplot().subplots(figsize=(9, 3.8), layout="constrained")
    temps, cutoff, t_an = curve["temps_c"], curve["cutoff_c"], curve["time_to_cutoff_analytic_s"]
    ax.plot(np.arange(len(temps)), temps, color=OURS_COLOUR, label="simulated (eq 7)")
    ax.plot([0, t_an], [20, cutoff], color="0.3", ls="--", label=f"m·c_p·ΔT / mean net heat\n= {t_an:.0f} s")
    ax.axhline(cutoff, color="#6a3d9a", ls="-.", lw=1.4, label=f"motor cutoff {cutoff:g} °C")
    ax.set(xlabel="time (s)", ylabel="motor temperature (°C)", ylim=(0.0, cutoff + 8))
    ax.grid(alpha=0.3)
    ax.set_title("Motor at peak power (90 kW), coolant off, from 20 °C (no paper figure: checks eq 7)", fontsize=10)
    _legend(fig, ax)
    return save_fig(fig, path)


def cycle_figure(cycle: str, traces: dict[str, dict[str, np.ndarray]], figures: dict[str, Any], path: Path) -> Path:
    """Figs 7-10 analog on ``cycle``: motor temperature and heat index, thermal model on and off, with the
    paper's bands (Figs 7-8 on ``udds`` and ``hwfet``, Figs 9-10 on ``beijing``); ``figures``: the thermal-model
    run's :func:`~.measure.cycle_run` figures."""
    on, off = traces["with_thermal"], traces["without_thermal"]
    t = np.arange(1, len(on["motor_temp_c"]) + 1)
    fig, (ax_t, ax_h) = pyplot().subplots(2, 1, figsize=(10.5, 6.0), sharex=True, layout="constrained")
    ax_t.plot(t, off["motor_temp_c"], color=OFF_COLOUR, lw=1.0, label="ours, thermal model off")
    ax_t.plot(t, on["motor_temp_c"], color=OURS_COLOUR, lw=1.4, label="ours, thermal model on: stator/housing")
    if "winding_temp_c" in on:
        ax_t.plot(t, on["winding_temp_c"], color=OURS_COLOUR, lw=0.8, ls="--", alpha=0.7,
                  label="ours, thermal model on: winding")
    ax_h.plot(t, on["heat_index"], color=OURS_COLOUR, lw=1.4, clip_on=False)
    if cycle in ("udds", "hwfet"):
        _figs_7_8(ax_t, ax_h, t, figures)
        which = "Figs 7-8 (captioned UDDS, text: HWFET)"
    elif cycle == "beijing":
        _figs_9_10(ax_t, ax_h, t, figures)
        which = "Figs 9-10 (ours: a synthetic Beijing-like cycle)"
    else:
        which = "figures: none for this cycle"
    ax_t.set_ylabel("motor temperature (°C)")
    ax_h.set(ylabel="heat index PWM (-)", ylim=(0.0, 1.0), xlabel="time (s)")
    for ax in (ax_t, ax_h):
        ax.grid(alpha=0.3)
    _legend(fig, ax_t, ax_h)
    ax_t.set_title(f"{cycle}, rule strategy, paper scenario: motor temperature", fontsize=10)
    ax_h.set_title("heat index", fontsize=10)
    figure_title(fig, f"{cycle} against the paper's {which}", fontsize=10.5)
    return save_fig(fig, path)


def _band(ax, lo: float, hi: float, x0: float, x1: float, label: str) -> None:
    ax.fill_between([x0, x1], [lo, lo], [hi, hi], color=BAND_COLOUR, alpha=0.35, lw=0, label=label)


def _figs_7_8(ax_t, ax_h, t: np.ndarray, figures: dict[str, Any]) -> None:
    peak, last, onset, hi_peak = (FIGURES[k] for k in ("udds_temp_peak_c", "udds_temp_last300_c", "udds_hi_onset_s",
                                                 "udds_hi_peak"))
    _band(ax_t, peak.paper - peak.tol, peak.paper + peak.tol, t[0], t[-1],
          f"paper: peak {peak.paper:g} ± {peak.tol:g} °C")
    ax_t.fill_between([t[-1] - 300, t[-1]], last.paper - last.tol, last.paper + last.tol, color=PAPER_COLOUR,
                      alpha=0.25, lw=0, label=f"paper: last 300 s {last.paper:g} ± {last.tol:g} °C")
    _band(ax_h, hi_peak.paper - hi_peak.tol, hi_peak.paper + hi_peak.tol, t[0], t[-1],
          f"paper: heat index peak {hi_peak.paper:g} ± {hi_peak.tol:g}")
    ax_h.errorbar([onset.paper], [0.0], xerr=[[onset.tol], [onset.tol]], marker="D", ms=8, mfc="none",
                  mec=PAPER_COLOUR, mew=1.8, color=PAPER_COLOUR, capsize=4, ls="none", clip_on=False,
                  label=f"paper: first above 0 at {onset.paper:g} ± {onset.tol:g} s")
    if figures["hi_onset_observed"]:
        ax_h.plot([figures["hi_onset_s"]], [0.0], marker="o", ms=7, color=OURS_COLOUR, ls="none", clip_on=False,
                  label=f"ours: first above 0 at {figures['hi_onset_s']:.0f} s")


def _figs_9_10(ax_t, ax_h, t: np.ndarray, figures: dict[str, Any]) -> None:
    band, mean, hi_max = FIGURES["beijing_warm_band"], FIGURES["beijing_temp_warm_mean_c"], FIGURES["beijing_hi_max"]
    start = figures["warm_from_s"] if math.isfinite(figures["warm_from_s"]) else t[0]
    _band(ax_t, band.low, band.high, start, t[-1],
          f"paper: {band.low:g}-{band.high:g} °C from {band.start_at:g} °C on (H1)")
    ax_t.axhline(mean.paper, color=PAPER_COLOUR, ls=":", lw=1.2, label=f"paper: mean {mean.paper:g} ± {mean.tol:g} °C")
    _band(ax_h, 0.0, hi_max.tol, t[0], t[-1], f"paper: heat index 0 (≤ {hi_max.tol:g} accepted)")


def fuel_levels_figure(level_rows: list[dict[str, Any]], path: Path) -> Path:
    """Raw fuel of ours against the paper's Table 2 (and our corrected fuel), on an axis from 0."""
    fig, ax = pyplot().subplots(figsize=(10.5, 0.42 * len(level_rows) + 1.6), layout="constrained")
    y = np.arange(len(level_rows))
    ours = [r["ours_l100"] for r in level_rows]
    ax.barh(y, ours, height=0.55, color=OURS_COLOUR, label="ours, raw fuel")
    ax.plot([r["ours_corrected_l100"] for r in level_rows], y, ls="none", marker="|", ms=14, mew=2, color="k",
            label="ours, corrected fuel (not compared)")
    ax.plot([r["paper_l100"] for r in level_rows], y, ls="none", marker="D", ms=8, mfc="none", mec=PAPER_COLOUR,
            mew=2, label="paper, Table 2 (raw)")
    for yi, r in zip(y, level_rows):
        ax.annotate(f"{r['gap_pct']:+.0f} % vs paper", (max(r["ours_l100"], r["paper_l100"]), yi), xytext=(10, 0),
                    textcoords="offset points", va="center", fontsize=8)
    ax.set(yticks=y, ylim=(len(level_rows) - 0.5, -0.5), xlabel="fuel (L/100 km), rule strategy, paper scenario",
           xlim=(0.0, max(max(ours), max(r["paper_l100"] for r in level_rows)) * 1.25))
    ax.set_yticklabels([f"{r['cycle']} (paper: {'highway row' if r['paper_row'] == 'highway' else 'Beijing'}), "
                        f"thermal {r['thermal_model']}" for r in level_rows], fontsize=8.5)
    ax.grid(axis="x", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda i: not labels[i].startswith("ours, raw"))
    legend_outside(fig, [handles[i] for i in order], [labels[i] for i in order])
    figure_title(fig, "Absolute fuel levels against the paper's Table 2 (different bus; beijing is synthetic)",
                 fontsize=10.5)
    return save_fig(fig, path)
