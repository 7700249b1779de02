"""The report's opening tables: every paper figure with ours, the difference and a verdict, the
summary of agreement, and the absolute fuel levels against the paper's Table 2."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .figures import PAPER_FIGURE_BY_NAME, PAPER_FIGURES, TABLE2_ROWS, PaperFigure

WITHIN, OUTSIDE = "within tolerance", "OUTSIDE tolerance"


def _num(x: float, unit: str = "") -> str:
    if x is None or not math.isfinite(x):
        return "never" if x is not None else "not observed"
    text = f"{x:.3g}" if abs(x) < 10 else f"{x:.1f}"
    return f"{text} {unit}".rstrip(" -") if unit else text


def verdict_rows(ours: Mapping[str, Any], figures: tuple[PaperFigure, ...] = PAPER_FIGURES) -> list[dict[str, Any]]:
    """One row per judged figure: paper, ours, difference (absolute and %), residual and verdict."""
    rows = []
    for f in figures:
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
    groups: dict[str, list[int]] = {}
    for r in rows:
        g = groups.setdefault(r["figure"], [0, 0])
        g[0] += r["within"]
        g[1] += 1
    return {"within": sum(r["within"] for r in rows), "total": len(rows),
            "by_figure": {k: {"within": a, "total": b} for k, (a, b) in groups.items()},
            "outside": [r["name"] for r in rows if not r["within"]]}


def summary_line(agr: dict[str, Any]) -> str:
    parts = ", ".join(f"{k} {v['within']}/{v['total']}" for k, v in agr["by_figure"].items())
    return (f"**Agreement: {agr['within']} of {agr['total']} paper figures within tolerance** ({parts}).")


def verdict_markdown(rows: list[dict[str, Any]]) -> list[str]:
    lines = ["| # | paper figure | quantity | paper | tolerance | ours | ours − paper | % | verdict |",
             "|---|---|---|---|---|---|---|---|---|"]
    for i, r in enumerate(rows, 1):
        diff = "" if r["difference"] is None else f"{r['difference']:+.3g}"
        pct = "" if r["difference_pct"] is None else f"{r['difference_pct']:+.1f} %"
        lines.append(f"| {i} | {r['figure']} | {r['description']} | {_num(r['paper'], r['unit'])} | {r['tolerance']} | "
                     f"{_num(r['ours'], r['unit'])} | {diff} | {pct} | {r['verdict']} |")
    return lines


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


def fuel_level_markdown(rows: list[dict[str, Any]]) -> list[str]:
    lines = ["| our cycle | paper's row | thermal model | paper (L/100 km) | ours, raw | ours − paper | % | "
             "ours, corrected (not compared) |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        row = "highway (labelled UDDS)" if r["paper_row"] == "highway" else "Beijing"
        lines.append(f"| {r['cycle']} | {row} | {r['thermal_model']} | {r['paper_l100']:.1f} | {r['ours_l100']:.2f} | "
                     f"{r['gap_l100']:+.2f} | {r['gap_pct']:+.1f} % | {r['ours_corrected_l100']:.2f} |")
    return lines
