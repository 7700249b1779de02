"""The figures: produced, legends outside the data, honest axes, limits drawn, the learned policy set
apart, a training curve without episodes; the env's frame uncut."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from hev_thermal_env.evaluation.plots import (
    FUEL_CHART_FILE,
    SPLIT_INFO_KEY,
    fuel_figure,
    plot_benchmark,
    plot_fuel_chart,
    run_figure,
)
from hev_thermal_env.evaluation.styles import close, is_learned, ordered
from hev_thermal_env.training.curves import training_curve_figure

STRATEGIES = ("ppo", "dp", "rule", "engine_only", "ecms", "ppo:runs/a/model.zip", "dp_thermal")


def assert_legends_outside_axes(fig) -> None:
    """No legend's box overlaps the data area (axes patch) of any axes of ``fig``."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert legends, "the figure has no legend"
    for leg in legends:
        box = leg.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), (leg.get_title().get_text(), ax.get_title())


def rows_for(cycles=("hwfet", "beijing"), scenarios=("paper", "hot")) -> list[dict]:
    rows = []
    for c in cycles:
        for s in scenarios:
            for i, st in enumerate(STRATEGIES):
                ratio = 1.0 if st == "dp_thermal" else 1.005 + 0.03 * i
                rows.append({"cycle": c, "scenario": s, "strategy": st, "frontier_ratio": ratio,
                             "fixed_price_ratio": ratio, "fuel_corrected_l_per_100km": 30.0 * ratio,
                             "reference": "dp_thermal: a grid"})
    return rows


def family_rows_for(cycles=("hwfet",), scenarios=("paper",), seeds=(1.02, 1.03, 1.05, 1.10)) -> list[dict]:
    """Benchmark rows plus a seed family "fam": its members' rows and its IQM row with an interval."""
    rows = rows_for(cycles, scenarios)
    for c in cycles:
        for s in scenarios:
            for k, v in enumerate(seeds):
                rows.append({"cycle": c, "scenario": s, "strategy": f"ppo:runs/s{k}", "family": "fam",
                             "frontier_ratio": v, "fuel_corrected_l_per_100km": 30.0 * v})
            rows.append({"cycle": c, "scenario": s, "strategy": "fam", "family": "fam", "frontier_ratio": 1.04,
                         "frontier_ratio_ci_low": 1.025, "frontier_ratio_ci_high": 1.08,
                         "fuel_corrected_l_per_100km": 31.2, "reference": "dp_thermal: a grid"})
    return rows


def fake_trace(n: int = 200, hot: bool = False, split: float = 0.3) -> dict[str, np.ndarray]:
    t = np.arange(1, n + 1, dtype=float)
    temp = (50.0 + 20.5 * t / n) if hot else 20.0 + 15.0 * t / n
    v = 10.0 + 5.0 * np.sin(t / 20)
    return {"time_s": t, "speed_mps": v - 0.1, "cycle_speed_mps": v, "soc": 0.65 - 0.01 * t / n,
            "motor_temp_c": temp, "heat_index": np.clip((t - n / 2) / n, 0, 1), SPLIT_INFO_KEY: np.full(n, split),
            "missed_wheel_energy_j": np.full(n, 1000.0), "motor_cutoff": temp >= 70.0,
            "shaft_torque_demand_nm": np.where(t % 10 < 3, -1.0, 100.0)}


# --- strategy order ---------------------------------------------------------------------------------

def test_strategies_run_from_the_simplest_to_the_optimum_then_learned():
    got = ordered(["ppo", "dp", "my_rule", "rule", "engine_only", "dp_thermal", "ppo:x", "ecms"])
    assert got == ["engine_only", "rule", "ecms", "my_rule", "dp", "dp_thermal", "ppo", "ppo:x"]
    assert is_learned("ppo:runs/x") and not is_learned("dp")


# --- fuel_vs_optimum.png ----------------------------------------------------------------------------

def test_fuel_chart_frontier_ratio_axis_from_1_shared_and_ordered(tmp_path):
    rows = rows_for()
    fig = fuel_figure(rows)
    try:
        axes = [ax for ax in fig.axes if ax.get_title()]
        assert [ax.get_title() for ax in axes] == ["hwfet cycle, paper scenario", "beijing cycle, paper scenario",
                                                   "hwfet cycle, hot scenario", "beijing cycle, hot scenario"]
        lims = {ax.get_xlim() for ax in axes}
        assert len(lims) == 1  # one range for every panel
        lo, hi = lims.pop()
        assert lo <= 1.0 <= hi and lo > 0.95 and hi >= max(r["frontier_ratio"] for r in rows)
        assert "frontier ratio" in fig.get_supxlabel() and "1 = dp_thermal: a grid" in fig.get_supxlabel()
        labels = [t.get_text() for t in axes[0].get_yticklabels()]
        assert labels[:6] == ["engine_only", "rule", "ecms", "dp (thermal-blind)", "dp_thermal", "ppo"]
        ticks = axes[0].get_yticks()
        assert ticks[5] - ticks[4] > 1.5  # the learned policies stand apart
        learned_colour = axes[0].get_yticklabels()[5].get_color()
        assert learned_colour != axes[0].get_yticklabels()[2].get_color()
        assert_legends_outside_axes(fig)
    finally:
        close(fig)
    path = plot_fuel_chart(rows, tmp_path / FUEL_CHART_FILE)
    assert path.stat().st_size > 20_000


def test_fuel_chart_shows_a_family_as_iqm_whiskers_and_seed_dots(tmp_path):
    rows = family_rows_for()
    fig = fuel_figure(rows)
    try:
        ax = fig.axes[0]
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert labels[-1] == "fam (4 seeds)" and not any(label.startswith("ppo:runs/s") for label in labels)
        y = ax.get_yticks()[-1]
        seeds = [ln for ln in ax.get_lines() if ln.get_marker() == "o" and len(ln.get_xdata()) == 4]
        assert len(seeds) == 1 and sorted(seeds[0].get_xdata()) == [1.02, 1.03, 1.05, 1.10]
        assert np.all(np.abs(np.asarray(seeds[0].get_ydata()) - y) < 0.5)  # on the family's row
        whiskers = [c for c in ax.collections if len(c.get_segments()) == 1
                    and np.allclose(sorted(np.asarray(c.get_segments()[0])[:, 0]), [1.025, 1.08])]
        assert whiskers  # the interval, from its low to its high end
        iqm = [ln for ln in ax.get_lines() if ln.get_marker() == "D" and list(ln.get_xdata()) == [1.04]]
        assert iqm and iqm[0].get_ydata()[0] == y
        assert any("1.040 [1.025, 1.080]" in t.get_text() for t in ax.texts)
        assert_legends_outside_axes(fig)
    finally:
        close(fig)
    assert plot_fuel_chart(rows, tmp_path / FUEL_CHART_FILE).stat().st_size > 20_000


def test_fuel_chart_wraps_many_cycles_onto_rows_of_four(tmp_path):
    cycles = tuple(f"validation_bus:{k}" for k in range(6))
    fig = fuel_figure(rows_for(cycles=cycles, scenarios=("paper", "hot")))
    try:
        panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title()]
        assert sorted(ax.get_title() for ax in panels) == sorted(f"{c} cycle, {s} scenario" for c in cycles
                                                                 for s in ("paper", "hot"))
        assert len({round(ax.get_position().x0, 3) for ax in panels}) == 4  # four columns
        assert len({round(ax.get_position().y0, 3) for ax in panels}) == 4  # two rows a scenario
        assert sum(not ax.get_visible() for ax in fig.axes) == 4
        assert fig.get_size_inches()[0] < 25.0
        assert_legends_outside_axes(fig)
    finally:
        close(fig)
    rows = rows_for(cycles=cycles)
    assert plot_fuel_chart(rows, tmp_path / FUEL_CHART_FILE).stat().st_size > 20_000


def test_fuel_chart_grows_one_row_per_scenario():
    fig = fuel_figure(rows_for(cycles=("hwfet", "beijing", "udds"), scenarios=("paper", "hot", "random", "x")))
    try:
        panels = [ax for ax in fig.axes if ax.get_title()]
        assert len(panels) == 12
        rows = sorted({round(ax.get_position().y0, 3) for ax in panels}, reverse=True)
        assert len(rows) == 4
        assert_legends_outside_axes(fig)
    finally:
        close(fig)


def test_fuel_chart_falls_back_to_the_fixed_price_ratio():
    rows = [dict(r, frontier_ratio=None) for r in rows_for()]
    fig = fuel_figure(rows)
    try:
        assert "fixed-price ratio" in fig.get_supxlabel() and fig.axes[0].get_xlim()[0] > 0.9
        assert not any(t.get_text().startswith("n/a") for t in fig.axes[0].texts)
    finally:
        close(fig)


def test_fuel_chart_marks_a_missing_ratio():
    rows = rows_for(cycles=("hwfet",), scenarios=("paper",))
    rows[2] = dict(rows[2], frontier_ratio=None, frontier_note="final SOC 0.5 outside the frontier's range")
    fig = fuel_figure(rows)
    try:
        assert [t.get_text() for t in fig.axes[0].texts if t.get_text().startswith("n/a")] == [
            "n/a (final SOC off the frontier)"]
    finally:
        close(fig)


# --- traces_<cycle>_<scenario>.png --------------------------------------------------------------------

def _lines_at(ax, y: float) -> list:
    return [ln for ln in ax.get_lines() if len(ln.get_ydata()) == 2 and np.allclose(ln.get_ydata(), y)]


def test_hot_trace_draws_the_cutoff_and_soft_limit():
    fig = run_figure({"rule": fake_trace(hot=True), "dp": fake_trace(hot=True), "ppo": fake_trace(hot=True)},
                     title="hot")
    try:
        ax_temp = fig.axes[3]
        assert _lines_at(ax_temp, 70.0) and _lines_at(ax_temp, 60.0)
        assert ax_temp.get_ylim()[1] > 70.0
        assert fig.axes[4].get_ylim() == (0.0, 1.0)  # heat index from 0 to 1
        assert len(fig.legends) == 2  # strategies, and the temperature limits
        assert_legends_outside_axes(fig)
    finally:
        close(fig)


def test_cool_trace_says_the_limits_are_far():
    fig = run_figure({"rule": fake_trace(), "ecms": fake_trace()})
    try:
        assert not _lines_at(fig.axes[3], 70.0)
        assert "far below" in fig.axes[3].get_title()
        assert_legends_outside_axes(fig)
    finally:
        close(fig)


def test_trace_panels_show_missed_energy_and_one_split_strip_per_strategy():
    traces = {"rule": fake_trace(split=0.5), "ecms": fake_trace(split=-0.5), "ppo": fake_trace()}
    fig = run_figure(traces)
    try:
        miss = fig.axes[1].get_lines()
        assert miss and max(ln.get_ydata()[-1] for ln in miss) == pytest.approx(200 * 1000 / 3.6e6)
        strips = fig.axes[5].get_images()[-1].get_array()
        assert strips.shape == (3, 200)
        assert strips.mask[:, 0].all()  # no traction torque demanded: u has no effect, drawn grey
        assert strips[0, 5] == 0.5 and strips[1, 5] == -0.5
        cycle_line = [ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("cycle")]
        assert len(cycle_line) == 1 and cycle_line[0].get_linewidth() > 3 * fig.axes[0].get_lines()[1].get_linewidth()
    finally:
        close(fig)


def test_plot_benchmark_writes_every_figure(tmp_path):
    rows = rows_for(cycles=("hwfet",), scenarios=("hot",))
    traces = {("hwfet", "hot", r["strategy"]): fake_trace(hot=True) for r in rows}
    plot_benchmark(tmp_path, rows, traces)
    for name in (FUEL_CHART_FILE, "traces_hwfet_hot.png"):
        assert (tmp_path / name).stat().st_size > 30_000, name


# --- training_curve.png -----------------------------------------------------------------------------

def test_training_curve_without_logged_episodes(tmp_path):
    (tmp_path / "config.yaml").write_text(yaml.safe_dump({"algo": "sac", "seed": 0, "env": {}}))
    fig = training_curve_figure(tmp_path)
    try:
        assert "no training episode" in fig.axes[0].texts[0].get_text()
    finally:
        close(fig)


# --- the env's rgb_array frame ----------------------------------------------------------------------

def test_render_frame_title_and_legend_inside_the_frame():
    import gymnasium as gym

    env = gym.make("HevThermal-v2", cycle="beijing", scenario="hot", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(30):
        env.step(np.array([0.5], np.float32))
    frame = env.render()
    plot = env.unwrapped._plot
    fig = plot.fig
    renderer = fig.canvas.get_renderer()
    w, h = frame.shape[1], frame.shape[0]
    for artist in (plot._title, *fig.legends):
        box = artist.get_window_extent(renderer)
        assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= w and box.y1 <= h, box
    assert "beijing" in plot._title.get_text()
    assert_legends_outside_axes(fig)
    env.close()
