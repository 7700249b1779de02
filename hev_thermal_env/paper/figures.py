"""The paper's figures and the tolerances we judge ours against: one table, :data:`PAPER_FIGURES`.

Each row names one quantity (the key of our measured value), the paper's figure, the paper's value and how far
ours may be from it: ``kind="abs"``, within ``paper ± tol`` (in the row's unit); ``"rel"``, within
``paper × (1 ± tol)``; ``"max"``, at most ``tol`` (the paper gives a value or a shape; the limit is what we ask);
``tol=None``, reported with its gap, not judged (Table 2's absolute fuel levels: our bus and our synthetic Beijing
cycle are not the paper's).

The rows come from Table 3 (coolant closed; 0-60 km/h, top and 4 % grade speed, thermal model off and on from a
30 or 50 °C start), Table 2 (fuel with and without the thermal model, ``rule``; its highway row is labelled UDDS
while the text says HWFET), Figs 7-8 (heat index and motor temperature, captioned UDDS), Figs 9-10 (Beijing) and
Fig. 4 (the heat index at twice the continuous torque from cold). The report judges every row
(:func:`verdict_rows`, :func:`agreement`; the fuel levels, :func:`fuel_level_rows`); the calibration fits
:data:`CALIBRATION_TARGETS` and holds the others out.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

#: The residual of a quantity that is never observed (a heat index that never rises, never returns).
UNOBSERVED_RESIDUAL = 10.0
WITHIN, OUTSIDE = "within tolerance", "OUTSIDE tolerance"


@dataclasses.dataclass(frozen=True)
class PaperFigure:
    """One of the paper's figures, its value and the tolerance of ours (see the module docstring)."""

    name: str
    figure: str
    description: str
    paper: float
    unit: str
    tol: float | None
    kind: str = "abs"

    @property
    def judged(self) -> bool:
        return self.tol is not None

    def within(self, value: float | None) -> bool | None:
        """Whether ``value`` meets the tolerance (None: not judged; a missing value does not meet it)."""
        if self.tol is None:
            return None
        if value is None or not math.isfinite(value):
            return False
        if self.kind == "max":
            return value <= self.tol + 1e-9
        lo, hi = ((self.paper * (1.0 - self.tol), self.paper * (1.0 + self.tol)) if self.kind == "rel"
                  else (self.paper - self.tol, self.paper + self.tol))
        return lo - 1e-9 <= value <= hi + 1e-9

    def residual(self, value: float) -> float:
        """Signed distance from the paper in tolerances: within the tolerance when in [-1, 1] (for an upper
        limit: value / limit). A value that is not finite (never observed) is :data:`UNOBSERVED_RESIDUAL`."""
        if not math.isfinite(value):
            return UNOBSERVED_RESIDUAL
        if self.kind == "max":
            return value / self.tol
        if self.kind == "rel":
            return (value - self.paper) / (self.tol * self.paper)
        return (value - self.paper) / self.tol

    def tolerance_text(self) -> str:
        if self.tol is None:
            return "not judged"
        if self.kind == "rel":
            return f"± {100 * self.tol:g} %"
        if self.kind == "max":
            return f"≤ {self.tol:g} {self.unit}".rstrip(" -")
        return f"± {self.tol:g} {self.unit}".rstrip(" -")


PAPER_FIGURES: tuple[PaperFigure, ...] = (
    PaperFigure("top_speed_off_kmh", "Table 3", "top speed, thermal model off", 89.0, "km/h", 0.07, "rel"),
    PaperFigure("top_speed_30c_kmh", "Table 3", "top speed, 30 °C start", 89.0, "km/h", 0.07, "rel"),
    PaperFigure("top_speed_50c_kmh", "Table 3", "top speed, 50 °C start", 89.0, "km/h", 0.07, "rel"),
    PaperFigure("accel_off_s", "Table 3", "0-60 km/h, thermal model off", 16.4, "s", 0.05, "rel"),
    PaperFigure("accel_30c_delta_s", "Table 3", "0-60 km/h: 30 °C start − thermal off (16.8 − 16.4 s)", 0.4, "s",
                0.2),
    PaperFigure("accel_50c_delta_s", "Table 3", "0-60 km/h: 50 °C start − thermal off (17.1 − 16.4 s)", 0.7, "s",
                0.2),
    PaperFigure("grade_off_kmh", "Table 3", "speed on a 4 % grade, thermal model off", 48.3, "km/h", 0.07, "rel"),
    PaperFigure("grade_30c_kmh", "Table 3", "speed on a 4 % grade, 30 °C start", 48.3, "km/h", 0.07, "rel"),
    PaperFigure("grade_50c_kmh", "Table 3", "speed on a 4 % grade, 50 °C start", 48.3, "km/h", 0.07, "rel"),
    PaperFigure("udds_fuel_delta_l100", "Table 2", "UDDS: raw fuel with − without thermal model", 0.3, "L/100 km",
                0.15),
    PaperFigure("hwfet_fuel_delta_l100", "Table 2", "HWFET (the text's cycle): raw fuel with − without thermal model",
                0.3, "L/100 km", 0.15),
    PaperFigure("beijing_fuel_delta_l100", "Table 2", "beijing: raw fuel with − without thermal model", 0.0,
                "L/100 km", 0.1),
    PaperFigure("udds_hi_onset_s", "Figs 7-8", "UDDS: heat index first above 0", 387.0, "s", 40.0),
    PaperFigure("udds_hi_peak", "Figs 7-8", "UDDS: heat index peak", 0.35, "-", 0.07),
    PaperFigure("udds_hi_return_s", "Figs 7-8", "UDDS: heat index back to 0, seconds after its peak", 300.0, "s",
                400.0, "max"),
    PaperFigure("udds_temp_peak_c", "Figs 7-8", "UDDS: motor temperature peak", 44.0, "°C", 2.0),
    PaperFigure("udds_temp_last300_c", "Figs 7-8", "UDDS: motor temperature, mean of the last 300 s", 37.5, "°C",
                1.5),
    PaperFigure("beijing_temp_c", "Figs 9-10", "beijing: motor temperature after warm-up (mean)", 35.0, "°C", 1.5),
    PaperFigure("beijing_hi_peak", "Figs 9-10", "beijing: heat index peak", 0.0, "-", 0.05, "max"),
    PaperFigure("fig4_leaves_zero_s", "Fig. 4", "2× continuous torque from cold: heat index leaves 0", 30.0, "s",
                1.0),
    PaperFigure("fig4_reaches_one_s", "Fig. 4", "2× continuous torque from cold: heat index reaches 1", 130.0, "s",
                1.0),
    PaperFigure("highway_fuel_without_l100", "Table 2", "highway row, thermal model off", 35.3, "L/100 km", None),
    PaperFigure("highway_fuel_with_l100", "Table 2", "highway row, thermal model on", 35.6, "L/100 km", None),
    PaperFigure("beijing_fuel_without_l100", "Table 2", "Beijing, thermal model off", 27.1, "L/100 km", None),
    PaperFigure("beijing_fuel_with_l100", "Table 2", "Beijing, thermal model on", 27.1, "L/100 km", None),
)
PAPER_FIGURE_BY_NAME = {f.name: f for f in PAPER_FIGURES}

#: The runs of Table 3 (coolant closed): thermal model off, and on from a 30 or 50 °C start.
TABLE3_RUNS = ("off", "30c", "50c")
#: Our cycles compared with the paper's Table 2 rows: (our cycle, the paper's row).
TABLE2_ROWS = (("hwfet", "highway"), ("udds", "highway"), ("beijing", "beijing"))
#: Cycles every verdict needs (Table 2 and Figs 7-10).
VERDICT_CYCLES = ("hwfet", "udds", "beijing")
#: The figures the calibration fits the thermal parameters to (:mod:`hev_thermal_env.calibration`), in the
#: order of its residual table. Top speed and grade speed are engine-alone speeds the thermal model cannot
#: change, and HWFET, Fig. 4 and the fuel levels are held out.
CALIBRATION_TARGETS = ("udds_hi_onset_s", "udds_hi_peak", "udds_hi_return_s", "udds_temp_peak_c",
                       "udds_temp_last300_c", "beijing_temp_c", "beijing_hi_peak", "udds_fuel_delta_l100",
                       "beijing_fuel_delta_l100", "accel_off_s", "accel_30c_delta_s", "accel_50c_delta_s")


def table3_paper(run: str) -> dict[str, float]:
    """The paper's Table 3 row of ``run`` (one of :data:`TABLE3_RUNS`): top speed, 0-60 km/h, 4 % grade speed."""
    off = PAPER_FIGURE_BY_NAME["accel_off_s"].paper
    accel = off if run == "off" else round(off + PAPER_FIGURE_BY_NAME[f"accel_{run}_delta_s"].paper, 6)
    return {"top_speed_kmh": PAPER_FIGURE_BY_NAME[f"top_speed_{run}_kmh"].paper, "accel_0_60_s": accel,
            "grade_4pct_speed_kmh": PAPER_FIGURE_BY_NAME[f"grade_{run}_kmh"].paper}


def verdict_rows(ours: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per judged figure: paper, ours, difference (absolute and %), residual and verdict."""
    rows = []
    for f in PAPER_FIGURES:
        if not f.judged:
            continue
        v = ours.get(f.name)
        ok = f.within(v)
        finite = v is not None and math.isfinite(v)
        diff = v - f.paper if finite else None
        rows.append({"name": f.name, "figure": f.figure, "description": f.description, "unit": f.unit,
                     "paper": f.paper, "tolerance": f.tolerance_text(), "ours": v, "difference": diff,
                     "difference_pct": 100.0 * diff / abs(f.paper) if finite and f.paper else None,
                     "residual": f.residual(v) if finite else None, "within": bool(ok),
                     "verdict": WITHIN if ok else OUTSIDE})
    return rows


def agreement(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """n of m within tolerance, overall and per paper figure."""
    by_figure = {f: [r["within"] for r in rows if r["figure"] == f] for f in dict.fromkeys(r["figure"] for r in rows)}
    return {"within": sum(r["within"] for r in rows), "total": len(rows),
            "by_figure": {f: {"within": sum(w), "total": len(w)} for f, w in by_figure.items()},
            "outside": [r["name"] for r in rows if not r["within"]]}


def fuel_level_rows(cycles: Mapping[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Our raw fuel against the paper's Table 2 levels, like with like (raw with raw), per cycle and thermal model."""
    rows = []
    for cyc, paper_row in TABLE2_ROWS:
        if cyc not in cycles:
            continue
        for label, thermal in (("without_thermal", "off"), ("with_thermal", "on")):
            p = PAPER_FIGURE_BY_NAME[f"{paper_row}_fuel_{label.split('_')[0]}_l100"].paper
            ours = cycles[cyc][label]["fuel_l100"]
            rows.append({"cycle": cyc, "paper_row": paper_row, "thermal_model": thermal, "paper_l100": p,
                         "ours_l100": ours, "gap_l100": ours - p, "gap_pct": 100.0 * (ours - p) / p,
                         "ours_corrected_l100": cycles[cyc][label]["fuel_corrected_l100"]})
    return rows
