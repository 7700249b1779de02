"""The paper report's opening table: one verdict per paper figure, a summary of agreement, raw fuel
against the paper's Table 2 levels."""

from __future__ import annotations

import math

import pytest

from hev_thermal_env.paper.figures import (
    OUTSIDE,
    PAPER_FIGURE_BY_NAME,
    PAPER_FIGURES,
    WITHIN,
    PaperFigure,
    agreement,
    fuel_level_rows,
    table3_paper,
    verdict_rows,
)
from hev_thermal_env.paper.report import summary_line, verdict_markdown


def test_tolerance_kinds():
    band = PaperFigure("a", "Fig", "x", 387.0, "s", 40.0)
    rel = PaperFigure("b", "Tab", "y", 16.4, "s", 0.05, "rel")
    upper = PaperFigure("c", "Fig", "z", 300.0, "s", 400.0, "max")
    assert band.within(347.0) and band.within(427.0) and not band.within(428.0)
    assert rel.within(16.4 * 1.05) and not rel.within(16.4 * 0.94)
    assert upper.within(0.0) and upper.within(400.0) and not upper.within(401.0)
    assert band.within(None) is False and band.within(math.inf) is False
    assert PaperFigure("d", "Tab", "w", 35.3, "L/100 km", None).within(30.0) is None
    assert band.residual(427.0) == pytest.approx(1.0) and rel.residual(16.4) == 0.0
    assert (band.tolerance_text(), rel.tolerance_text(), upper.tolerance_text()) == ("± 40 s", "± 5 %", "≤ 400 s")


def test_the_table_holds_the_stated_tolerances():
    f = PAPER_FIGURE_BY_NAME
    assert (f["udds_hi_onset_s"].paper, f["udds_hi_onset_s"].tol) == (387.0, 40.0)
    assert (f["udds_hi_peak"].paper, f["udds_hi_peak"].tol) == (0.35, 0.07)
    assert (f["udds_hi_return_s"].tol, f["udds_hi_return_s"].kind) == (400.0, "max")
    assert (f["udds_temp_peak_c"].tol, f["udds_temp_last300_c"].tol, f["beijing_temp_c"].tol) == (2.0, 1.5, 1.5)
    assert (f["beijing_hi_peak"].tol, f["beijing_hi_peak"].kind) == (0.05, "max")
    assert (f["udds_fuel_delta_l100"].paper, f["udds_fuel_delta_l100"].tol) == (0.3, 0.15)
    assert f["beijing_fuel_delta_l100"].tol == 0.1
    assert (f["accel_off_s"].paper, f["accel_off_s"].tol, f["accel_off_s"].kind) == (16.4, 0.05, "rel")
    assert (f["accel_30c_delta_s"].paper, f["accel_50c_delta_s"].paper) == (0.4, 0.7)
    assert f["top_speed_off_kmh"].tol == f["grade_off_kmh"].tol == 0.07
    assert len({x.name for x in PAPER_FIGURES}) == len(PAPER_FIGURES)


def test_every_judged_row_gets_a_verdict_and_the_summary_counts_them():
    ours = {f.name: f.paper for f in PAPER_FIGURES}
    ours["udds_temp_peak_c"] = 35.1  # outside 44 ± 2
    ours["udds_hi_onset_s"] = None  # never rises: not observed counts as outside
    rows = verdict_rows(ours)
    judged = [f for f in PAPER_FIGURES if f.judged]
    assert len(rows) == len(judged)
    assert {r["verdict"] for r in rows} == {WITHIN, OUTSIDE}
    by = {r["name"]: r for r in rows}
    assert by["udds_temp_peak_c"]["difference"] == pytest.approx(-8.9)
    assert by["udds_temp_peak_c"]["difference_pct"] == pytest.approx(-8.9 / 44 * 100)
    assert by["udds_hi_onset_s"]["verdict"] == OUTSIDE
    agr = agreement(rows)
    assert (agr["within"], agr["total"]) == (len(rows) - 2, len(rows))
    line = summary_line(agr)
    assert f"{len(rows) - 2} of {len(rows)} paper figures within tolerance" in line and "Figs 7-8 3/5" in line
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
    assert hw["gap_pct"] == pytest.approx(100 * (29.6 - 35.3) / 35.3)
    assert rows[2]["paper_l100"] == 27.1 and rows[2]["gap_pct"] > 0


def test_table3_as_printed_from_the_table():
    assert table3_paper("off") == {"top_speed_kmh": 89.0, "accel_0_60_s": 16.4, "grade_4pct_speed_kmh": 48.3}
    assert (table3_paper("30c")["accel_0_60_s"], table3_paper("50c")["accel_0_60_s"]) == (16.8, 17.1)
