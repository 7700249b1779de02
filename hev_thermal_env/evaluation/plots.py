"""Plots of runs: speed against the cycle, SOC, motor temperature, heat index and split over time.

:func:`plot_run` overlays any number of runs (one per strategy) on shared axes, so the benchmark
and ``evaluate.py run`` draw the same figure; :func:`plot_benchmark` draws the benchmark's figures
(one :func:`plot_run` per cycle and scenario, and the corrected fuel relative to DP). Every PNG is
written atomically (:func:`hev_thermal_env.io.save_png`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hev_thermal_env.io import save_png

NON_INTERACTIVE_BACKENDS = ("agg", "pdf", "svg", "ps", "cairo")

PANELS = (
    ("speed_mps", "speed (km/h)", 3.6),
    ("soc", "battery SOC (-)", 1.0),
    ("motor_temp_c", "motor temperature (°C)", 1.0),
    ("heat_index", "heat index PWM (-)", 1.0),
    ("motor_share", "split u: motor share (-)", 1.0),
)


def pyplot():
    """``matplotlib.pyplot``, drawing off screen (Agg) unless a non-interactive backend is already chosen."""
    import matplotlib

    if matplotlib.get_backend().lower() not in NON_INTERACTIVE_BACKENDS:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _series(trace: Mapping[str, np.ndarray], key: str) -> np.ndarray | None:
    if key in trace:
        return np.asarray(trace[key], dtype=float)
    if key == "motor_share" and "u" in trace:
        return np.asarray(trace["u"], dtype=float)
    return None


def plot_run(traces: Mapping[str, Mapping[str, np.ndarray]], path: str | os.PathLike, title: str = "") -> Path:
    """Draw one or more runs (``{label: trace}``) into a PNG at ``path``; returns the path.

    Each trace needs per-step arrays ``speed_mps``, ``soc``, ``motor_temp_c``, ``heat_index`` and
    ``motor_share`` (or ``u``); ``time_s`` and ``cycle_speed_mps`` are used when present (the cycle's
    speed is drawn once, dashed, from the first trace that has it).
    """
    plt = pyplot()
    if not traces:
        raise ValueError("plot_run: no traces to plot")
    fig, axes = plt.subplots(len(PANELS), 1, figsize=(10, 11), sharex=True)
    cycle_drawn = False
    for label, tr in traces.items():
        n = len(next(iter(tr.values())))
        t = np.asarray(tr["time_s"], dtype=float) if "time_s" in tr else np.arange(1, n + 1, dtype=float)
        if not cycle_drawn and "cycle_speed_mps" in tr:
            axes[0].plot(t, np.asarray(tr["cycle_speed_mps"], dtype=float) * 3.6, color="k", lw=1.6, ls="--",
                         alpha=0.6, label="cycle")
            cycle_drawn = True
        for ax, (key, _, scale) in zip(axes, PANELS):
            y = _series(tr, key)
            if y is not None:
                ax.plot(t, y * scale, lw=1.0, label=str(label))
    for ax, (_, ylabel, _) in zip(axes, PANELS):
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[3].set_ylim(-0.03, 1.03)
    axes[4].set_ylim(-1.05, 1.05)
    axes[0].legend(loc="upper right", fontsize=8, ncol=min(4, len(traces) + 1))
    axes[0].set_title("vehicle speed vs the cycle")
    axes[1].set_title("battery state of charge")
    axes[2].set_title("motor temperature")
    axes[3].set_title("heat index (0 = full peak torque, 1 = continuous torque only)")
    axes[4].set_title("torque split (u > 0 motor assists, u < 0 engine charges the battery)")
    axes[-1].set_xlabel("time (s)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = save_png(fig, path)
    plt.close(fig)
    return path


def plot_benchmark(out: Path, rows: list[dict], traces: dict) -> None:
    """``out/traces_<cycle>_<scenario>.png`` (every strategy of a cycle and scenario on shared axes) and
    ``out/fuel_vs_dp.png``; ``traces`` maps (cycle, scenario, strategy) to a run's trace."""
    groups = sorted({(r["cycle"], r["scenario"]) for r in rows})
    for cyc, sc in groups:
        group = {st: tr for (c, s, st), tr in traces.items() if c == cyc and s == sc}
        plot_run(group, out / f"traces_{cyc}_{sc}.png", title=f"{cyc} cycle, {sc} scenario: every strategy")
    plot_fuel_vs_dp(rows, groups, out / "fuel_vs_dp.png")


def plot_fuel_vs_dp(rows: list[dict], groups: list[tuple[str, str]], path: Path) -> Path:
    """Bar chart per (cycle, scenario): corrected fuel relative to DP (in L/100 km when DP did not run)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(groups), figsize=(4.2 * len(groups), 4.0), squeeze=False)
    for ax, (cyc, sc) in zip(axes[0], groups):
        sel = [r for r in rows if r["cycle"] == cyc and r["scenario"] == sc]
        has_dp = any(r["fuel_vs_dp_pct"] for r in sel)
        vals = [r["fuel_vs_dp_pct"] if has_dp else r["fuel_corrected_l_per_100km"] for r in sel]
        names = [r["strategy"] for r in sel]
        bars = ax.bar(range(len(sel)), vals, color=["tab:grey" if n.startswith("dp") else "tab:blue" for n in names])
        for b, v in zip(bars, vals):
            ax.text(b.get_x() + b.get_width() / 2, b.get_height(), f"{v:.1f}", ha="center", va="bottom", fontsize=8)
        ax.set_xticks(range(len(sel)))
        ax.set_xticklabels(names, rotation=35, ha="right")
        if has_dp:
            ax.axhline(100.0, color="k", lw=0.8)
            ax.set_ylim(min(95.0, min(vals) - 2), max(vals) * 1.05)
        ax.set_ylabel("corrected fuel, % of DP" if has_dp else "corrected fuel (L/100 km)")
        ax.set_title(f"{cyc} / {sc}")
    fig.suptitle("Corrected fuel relative to the DP optimum (lower is better)")
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)
    return path
