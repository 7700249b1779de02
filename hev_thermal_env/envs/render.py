"""Drawing of an episode of ``HevThermal-v2`` so far, 640 × 640 pixels: a title row (cycle, time, legend) above five
stacked panels (speed against the cycle, SOC, motor temperature, heat index, the torque split). Imported only when an
env renders (matplotlib is slow to import).
"""

from __future__ import annotations

import math

import numpy as np

from ..cycles import Cycle
from ..physics.config import VehicleConfig

WIDTH_IN, HEIGHT_IN, DPI = 8.0, 8.0, 80  # 640 × 640 pixels
FONT_PT = 9.5

#: The step-info key (and history key) of the torque split chosen by the agent.
SPLIT_INFO_KEY = "motor_share"
#: The five panels, top to bottom: the history key drawn, the y label and the line's style.
_PANELS = (("speed_mps", "speed\n[km/h]", {"color": "C0", "lw": 1.2, "label": "vehicle"}),
           ("soc", "SOC [-]", {"color": "C2"}), ("motor_temp_c", "motor\n[°C]", {"color": "C3"}),
           ("heat_index", "heat\nindex [-]", {"color": "C1", "clip_on": False}),
           (SPLIT_INFO_KEY, "split u [-]\n(+ motor)", {"color": "C4", "lw": 0.8}))


class EpisodePlot:
    """One figure with five stacked panels, redrawn from the episode's history on each :meth:`draw`: in a pyplot window
    (``human``, paused at ``fps`` when the backend is interactive) or an off-screen canvas (:meth:`to_rgb`)."""

    def __init__(self, human: bool, fps: float = 30.0):
        self.human, self.fps = human, float(fps)
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
        import matplotlib

        with matplotlib.rc_context({"font.size": FONT_PT}):
            ax_v, _, ax_t, ax_hi, ax_u = self.axes
            self._cycle_line, = ax_v.plot([], [], color="0.75", lw=3.0, label="cycle")
            for ax, (name, ylabel, style) in zip(self.axes, _PANELS):
                self._lines[name], = ax.plot([], [], **style)
                ax.set_ylabel(ylabel)
                ax.grid(alpha=0.3)
                ax.tick_params(labelsize=FONT_PT - 1)
            self._cutoff_line = ax_t.axhline(math.nan, color="#6a3d9a", ls="-.", lw=1.2, label="cutoff")
            self._release_line = ax_t.axhline(math.nan, color="#e08214", ls=":", lw=1.2, label="cutoff release")
            ax_hi.set_ylim(0.0, 1.0)
            ax_u.axhline(0.0, color="0.6", lw=0.6)
            ax_u.set_ylim(-1.05, 1.05)
            ax_u.set_xlabel("time [s]")
            handles = [self._cycle_line, self._lines["speed_mps"], self._cutoff_line, self._release_line]
            self.fig.legend(handles, ["cycle", "vehicle", "motor cutoff", "cutoff release"], loc="upper right",
                            ncol=2, fontsize=FONT_PT - 1, frameon=False, bbox_to_anchor=(0.995, 0.995))
            self._title = self.fig.text(0.01, 0.985, "HevThermal", ha="left", va="top", fontsize=FONT_PT + 1.5,
                                        fontweight="bold")
            self.fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.94), h_pad=0.4)

    def draw(self, history: dict[str, list], cycle: Cycle | None, config: VehicleConfig,
             env_id: str = "HevThermal-v2") -> None:
        """Redraw the panels from ``history`` (lists per quantity, as the env records them)."""
        if cycle is not None and cycle is not self._cycle:
            self._cycle = cycle
            self._cycle_line.set_data(cycle.time_s, np.asarray(cycle.speed_mps) * 3.6)
            self.axes[0].set_xlim(0.0, max(cycle.duration_s, 1.0))
            self.axes[0].set_ylim(0.0, max(cycle.max_speed_kmh * 1.1, 10.0))
            self._cutoff_line.set_ydata([config.thermal.cutoff_temp_c] * 2)
            self._release_line.set_ydata([config.thermal.cutoff_release_temp_c] * 2)
        t = history.get("time_s", [])
        for name, line in self._lines.items():
            y = np.asarray(history.get(name, []), dtype=float)
            line.set_data(t, y * 3.6 if name == "speed_mps" else y)
        name = cycle.name if cycle is not None else "no cycle"
        self._title.set_text(f"{env_id}: {name}, t = {t[-1]:.0f} s" if t else f"{env_id}: {name}")
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
