"""Drawing of an episode of ``HevThermal-v0`` so far: speed against the cycle, SOC, motor temperature,
heat index and the torque split. Imported only when an env renders (matplotlib is slow to import).
"""

from __future__ import annotations

import math

import numpy as np

from ..cycles import Cycle
from ..physics.config import VehicleConfig

WIDTH_IN, HEIGHT_IN, DPI = 8.0, 8.0, 80  # 640 × 640 pixels


class EpisodePlot:
    """One figure with five stacked panels, redrawn from the episode's history on each :meth:`draw`.

    ``human=True`` uses a pyplot window (shown and paused at ``fps`` when the backend is
    interactive); otherwise an off-screen Agg canvas whose pixels :meth:`to_rgb` returns.
    """

    def __init__(self, human: bool, fps: float = 30.0):
        self.human = human
        self.fps = float(fps)
        if human:
            import matplotlib.pyplot as plt

            self._plt = plt
            self.fig = plt.figure(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)
        else:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            self._plt = None
            self.fig = Figure(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)
            FigureCanvasAgg(self.fig)
        self.axes = self.fig.subplots(5, 1, sharex=True)
        self._lines: dict[str, object] = {}
        self._cycle: Cycle | None = None
        self._build()

    def _build(self) -> None:
        ax_v, ax_soc, ax_t, ax_hi, ax_u = self.axes
        self._cycle_line, = ax_v.plot([], [], color="0.6", lw=1.0, label="cycle")
        self._lines["speed_mps"], = ax_v.plot([], [], color="C0", lw=1.2, label="vehicle")
        ax_v.set_ylabel("speed\n[km/h]")
        ax_v.legend(loc="upper right", fontsize=7)
        self._lines["soc"], = ax_soc.plot([], [], color="C2")
        ax_soc.set_ylabel("SOC [-]")
        self._lines["motor_temp_c"], = ax_t.plot([], [], color="C3")
        self._cutoff_line = ax_t.axhline(math.nan, color="C3", ls="--", lw=0.8)
        ax_t.set_ylabel("motor\n[°C]")
        self._lines["heat_index"], = ax_hi.plot([], [], color="C1")
        ax_hi.set_ylabel("heat\nindex [-]")
        ax_hi.set_ylim(-0.05, 1.05)
        self._lines["motor_share"], = ax_u.plot([], [], color="C4", lw=0.8)
        ax_u.set_ylabel("split u [-]")
        ax_u.set_ylim(-1.05, 1.05)
        ax_u.set_xlabel("time [s]")
        self.fig.tight_layout()

    def draw(self, history: dict[str, list], cycle: Cycle | None, config: VehicleConfig) -> None:
        """Redraw the panels from ``history`` (lists per quantity, as the env records them)."""
        if cycle is not None and cycle is not self._cycle:
            self._cycle = cycle
            self._cycle_line.set_data(cycle.time_s, np.asarray(cycle.speed_mps) * 3.6)
            self.axes[0].set_xlim(0.0, max(cycle.duration_s, 1.0))
            self.axes[0].set_ylim(0.0, max(cycle.max_speed_kmh * 1.1, 10.0))
            self._cutoff_line.set_ydata([config.thermal.cutoff_temp_c] * 2)
            self.axes[0].set_title(f"HevThermal-v0: {cycle.name}", fontsize=9)
        t = history.get("time_s", [])
        for name, line in self._lines.items():
            y = np.asarray(history.get(name, []), dtype=float)
            line.set_data(t, y * 3.6 if name == "speed_mps" else y)
        soc = history.get("soc", [])
        if soc:
            lo, hi = min(soc), max(soc)
            self.axes[1].set_ylim(lo - 0.02, hi + 0.02)
            temps = history["motor_temp_c"]
            self.axes[2].set_ylim(min(min(temps), 20.0) - 2.0, max(max(temps), config.thermal.cutoff_temp_c) + 5.0)
        if self.human:
            self.fig.canvas.draw_idle()
            if self.fig.canvas.required_interactive_framework is not None:  # a real window
                self._plt.pause(1.0 / self.fps)
        else:
            self.fig.canvas.draw()

    def to_rgb(self) -> np.ndarray:
        """The figure as an H×W×3 uint8 array."""
        buf = np.asarray(self.fig.canvas.buffer_rgba())
        return np.ascontiguousarray(buf[:, :, :3])

    def close(self) -> None:
        if self._plt is not None:
            self._plt.close(self.fig)
