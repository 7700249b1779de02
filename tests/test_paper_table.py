"""The paper's table of targets and checks (the one table, :mod:`tools.paper.figures`): their residuals and
verdicts, the measuring functions on synthetic traces, and the report's opening table."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from hev_thermal_env.physics.performance import table3_paper
from tools.paper import measure
from tools.paper.figures import (
    CHECK_NOTES,
    CHECKS,
    FITTED,
    HELD_OUT,
    PAPER_FIGURE_BY_NAME,
    PAPER_FIGURES,
    TARGETS,
    PaperFigure,
)
from tools.paper.report import summary_line, verdict_markdown
from tools.paper.verdicts import OUTSIDE, WITHIN, agreement, fuel_level_rows, verdict_rows

PROTOCOL = yaml.safe_load((Path(__file__).resolve().parents[1] / "docs" / "calibration" /
                           "parameter_ranges.yaml").read_text())


def test_the_budget_and_the_checks_are_the_protocols():
    assert sum(t.weight for t in FITTED) == PROTOCOL["budget"]["fitted_target_weight"] == 6.5
    assert [c.id for c in CHECKS] + list(CHECK_NOTES) == ["C1", "C1", "C2", "C2", "C2", "C2", "C3", "C4", "C5", "C6"]
    assert len({f.name for f in PAPER_FIGURES}) == len(PAPER_FIGURES)
    assert all(t.weight == 0.0 for t in HELD_OUT + CHECKS)


def test_residual_kinds():
    band = PaperFigure("X", "a", "Fig", "x", 387.0, "s", 40.0)
    one_sided = PAPER_FIGURE_BY_NAME["udds_hi_return_s"]  # ≤ 400 s, r = max(0, x − 0)/400
    rel = PAPER_FIGURE_BY_NAME["accel_off_s"]
    every = PAPER_FIGURE_BY_NAME["beijing_warm_band"]
    assert band.residual(427.0) == pytest.approx(1.0) and band.within(347.0) and not band.within(428.0)
    assert one_sided.residual(200.0) == 0.5 and one_sided.within(400.0) and not one_sided.within(401.0)
    assert PAPER_FIGURE_BY_NAME["beijing_hi_max"].residual(0.1) == pytest.approx(2.0)
    assert rel.residual(16.4 * 1.05) == pytest.approx(1.0) and not rel.within(16.4 * 0.94)
    assert every.within(0.0) and not every.within(0.1) and every.residual(3.0) == 1.0
    assert math.isnan(band.residual(float("nan"))) and not band.within(None) and not band.within(math.inf)
    assert (band.tolerance_text(), rel.tolerance_text(), one_sided.tolerance_text()) == ("± 40 s", "± 5 %", "≤ 400 s")


def test_heat_index_figures_interpolate_the_crossings():
    x = np.array([-0.3, -0.1, 0.1, 0.3, 0.2, -0.2, -0.3])
    f = measure.heat_index_figures({"heat_x": x, "heat_index": np.clip(x, 0, 1)})
    assert f["hi_onset_s"] == pytest.approx(2.5)  # between the ends of steps 2 (x −0.1) and 3 (x 0.1)
    assert f["hi_peak"] == 0.3 and f["hi_peak_time_s"] == 4.0
    assert f["hi_return_s"] == pytest.approx(5.5 - 4.0)  # x 0.2 → −0.2 between the ends of steps 5 and 6
    never = measure.heat_index_figures({"heat_x": np.full(10, -0.2), "heat_index": np.zeros(10)})
    assert never["hi_onset_s"] == pytest.approx(10 + measure.EXTENSION_S * 0.2) and never["hi_onset_observed"] == 0.0
    assert never["hi_return_s"] == 0.0
    stays = measure.heat_index_figures({"heat_x": np.array([-0.1, 0.2, 0.1]), "heat_index": np.array([0, 0.2, 0.1])})
    assert stays["hi_return_s"] == pytest.approx(3 + measure.EXTENSION_S * 0.1 - 2)


def test_warm_figures_measure_fig10_from_the_first_warm_second():
    temps = np.array([20.0, 30.0, 34.6, 36.0, 38.5, 31.0, 35.0])
    w = measure.warm_figures(temps)
    assert w["warm_from_s"] == 3.0 and w["temp_warm_mean_c"] == pytest.approx(np.mean(temps[2:]))
    assert w["warm_excursion_k"] == pytest.approx(1.0) and w["warm_seconds_outside"] == 2.0
    assert math.isnan(measure.warm_figures(np.full(5, 30.0))["temp_warm_mean_c"])


def test_target_values_map_every_target_to_its_run():
    cycles = {c: {"hi_onset_s": 1.0, "hi_peak": 2.0, "hi_return_s": 3.0, "temp_peak_c": 4.0, "temp_last300_c": 5.0,
                  "fuel_delta_l100": 6.0 + i, "warm_excursion_k": 7.0, "temp_warm_mean_c": 8.0, "hi_max": 9.0}
              for i, c in enumerate(measure.CYCLES)}
    ours = measure.target_values(cycles, {"accel_30c_delta_s": 10.0, "accel_50c_delta_s": 11.0})
    assert set(ours) == {t.name for t in TARGETS}
    assert (ours["udds_fuel_delta_l100"], ours["beijing_fuel_delta_l100"], ours["hwfet_fuel_delta_l100"]) == (6, 7, 8)
    assert (ours["beijing_warm_band"], ours["beijing_hi_max"], ours["accel_50c_delta_s"]) == (7, 9, 11)


def test_every_row_gets_a_verdict_and_the_summary_counts_them_per_group():
    ours = {f.name: f.paper for f in PAPER_FIGURES}
    ours["udds_temp_peak_c"] = 35.1  # outside 44 ± 2
    ours["beijing_temp_warm_mean_c"] = None  # never warm: not observed counts as outside
    rows = verdict_rows(ours)
    assert len(rows) == len(PAPER_FIGURES) and {r["verdict"] for r in rows} == {WITHIN, OUTSIDE}
    by = {r["name"]: r for r in rows}
    assert by["udds_temp_peak_c"]["difference"] == pytest.approx(-8.9) and by["udds_temp_peak_c"]["id"] == "F4"
    assert by["beijing_temp_warm_mean_c"]["verdict"] == OUTSIDE
    agr = agreement(rows)
    assert (agr["within"], agr["total"]) == (len(rows) - 2, len(rows))
    assert agr["by_group"]["fitted"] == {"within": 6, "total": 7}
    assert agr["by_group"]["held_out"] == {"within": 5, "total": 6}
    line = summary_line(agr)
    assert f"{len(rows) - 2} of {len(rows)} paper figures within tolerance" in line
    assert "fitted (F1-F7) 6/7" in line and "held out (H1-H6) 5/6" in line
    md = verdict_markdown(rows)
    assert len(md) == len(rows) + 2
    assert all(row.rstrip(" |").endswith(("within tolerance", "OUTSIDE tolerance")) for row in md[2:])


def test_fuel_levels_compare_raw_with_raw():
    cycles = {c: {"without_thermal": {"fuel_l100": 29.6, "fuel_corrected_l100": 34.3},
                  "with_thermal": {"fuel_l100": 29.7, "fuel_corrected_l100": 34.4}}
              for c in ("hwfet", "beijing")}
    rows = fuel_level_rows(cycles)
    assert [(r["cycle"], r["thermal_model"]) for r in rows] == [("hwfet", "off"), ("hwfet", "on"),
                                                                ("beijing", "off"), ("beijing", "on")]
    hw = rows[0]
    assert hw["paper_l100"] == 35.3 and hw["gap_l100"] == pytest.approx(29.6 - 35.3)
    assert rows[1]["paper_l100"] == 35.6 and rows[2]["paper_l100"] == 27.1


def test_table3_as_printed_from_the_table():
    assert table3_paper("off") == {"top_speed_kmh": 89.0, "accel_0_60_s": 16.4, "grade_4pct_speed_kmh": 48.3}
    assert (table3_paper("30c")["accel_0_60_s"], table3_paper("50c")["accel_0_60_s"]) == (16.8, 17.1)
