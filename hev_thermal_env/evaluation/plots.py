"""Plots of runs: speed against the cycle, SOC, motor temperature, heat index and split over time.

:func:`plot_run` overlays any number of runs (one per strategy) on shared axes, so the benchmark
and ``evaluate.py run`` draw the same figure.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

PANELS = (
    ("speed_mps", "speed (km/h)", 3.6),
    ("soc", "battery SOC (-)", 1.0),
    ("motor_temp_c", "motor temperature (°C)", 1.0),
    ("heat_index", "heat index PWM (-)", 1.0),
    ("action", "split u: motor share (-)", 1.0),
)


def _series(trace: Mapping[str, np.ndarray], key: str) -> np.ndarray | None:
    if key in trace:
        return np.asarray(trace[key], dtype=float)
    if key == "action" and "u" in trace:
        return np.asarray(trace["u"], dtype=float)
    return None


def plot_run(traces: Mapping[str, Mapping[str, np.ndarray]], path: str | os.PathLike, title: str = "") -> Path:
    """Draw one or more runs (``{label: trace}``) into a PNG at ``path``; returns the path.

    Each trace needs per-step arrays ``speed_mps``, ``soc``, ``motor_temp_c``, ``heat_index`` and
    ``action`` (or ``u``); ``time_s`` and ``cycle_speed_mps`` are used when present (the cycle's
    speed is drawn once, dashed, from the first trace that has it).
    """
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
