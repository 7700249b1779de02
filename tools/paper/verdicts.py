"""Ours against the paper's figures (:mod:`.figures`): a verdict row per figure, the agreement
per group and figure, and our absolute fuel beside Table 2's levels."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .figures import PAPER_FIGURES, TABLE2_LEVELS, TABLE2_ROWS, PaperFigure

WITHIN, OUTSIDE = "within tolerance", "OUTSIDE tolerance"
#: Cycles every verdict needs (Table 2 and Figs 7-10).
VERDICT_CYCLES = ("hwfet", "udds", "beijing")


def verdict_rows(ours: Mapping[str, Any], figures: tuple[PaperFigure, ...] = PAPER_FIGURES) -> list[dict[str, Any]]:
    """One row per figure: group, paper, ours, difference (absolute and %), residual and verdict."""
    rows = []
    for f in figures:
        v = ours.get(f.name)
        ok = f.within(v)
        finite = v is not None and math.isfinite(v)
        diff = v - f.paper if finite else None
        rows.append({"id": f.id, "name": f.name, "group": f.group, "figure": f.figure, "description": f.description,
                     "unit": f.unit, "paper": f.paper, "paper_text": f.paper_text(), "tolerance": f.tolerance_text(),
                     "ours": v, "difference": diff,
                     "difference_pct": 100.0 * diff / abs(f.paper) if finite and f.paper else None,
                     "residual": f.residual(v) if finite else None, "within": bool(ok),
                     "verdict": WITHIN if ok else OUTSIDE})
    return rows

def agreement(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """n of m within tolerance, overall, per group (fitted, held out, check) and per paper figure."""
    def count(key: str) -> dict[str, dict[str, int]]:
        keys = dict.fromkeys(r[key] for r in rows)
        return {k: {"within": sum(r["within"] for r in rows if r[key] == k),
                    "total": sum(r[key] == k for r in rows)} for k in keys}
    return {"within": sum(r["within"] for r in rows), "total": len(rows), "by_group": count("group"),
            "by_figure": count("figure"), "outside": [r["name"] for r in rows if not r["within"]]}

def fuel_level_rows(cycles: Mapping[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Our raw fuel against the paper's Table 2 levels, like with like (raw with raw), per cycle and thermal model."""
    rows = []
    for cyc, paper_row in TABLE2_ROWS:
        if cyc not in cycles:
            continue
        for label, thermal in (("without_thermal", "off"), ("with_thermal", "on")):
            p = TABLE2_LEVELS[(paper_row, thermal)]
            ours = cycles[cyc][label]["fuel_l100"]
            rows.append({"cycle": cyc, "paper_row": paper_row, "thermal_model": thermal, "paper_l100": p,
                         "ours_l100": ours, "gap_l100": ours - p, "gap_pct": 100.0 * (ours - p) / p,
                         "ours_corrected_l100": cycles[cyc][label]["fuel_corrected_l100"]})
    return rows
