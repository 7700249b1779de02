"""The benchmark's result files: ``results.csv``, ``results.json``, ``results.md`` (the runs and families, not the
members) and ``timings.json``, one row per cycle × scenario × strategy run, then the families' rows. Wall times go to
``timings.json`` only, so the other files are the same byte for byte run after run.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hev_thermal_env.io import atomic_write_json, atomic_write_text
from hev_thermal_env.physics import paper_bus
from hev_thermal_env.stats import CONFIDENCE

from .runner import jsonable
from .score import (
    ANCHOR,
    BLIND_DP,
    ILL_CONDITIONED,
    ILL_CONDITIONED_BELOW,
    REFERENCE,
    add_score_columns,
    display_name,
    is_family_row,
    score_text,
    strategy_aggregates,
)

COLUMNS = ("cycle", "scenario", "strategy", "family", "seeds", "distance_km", "fuel_g", "fuel_l_per_100km",
           "fuel_corrected_l_per_100km", "cost_g", "overheat_g", "frontier_ratio", "frontier_ratio_ci_low",
           "frontier_ratio_ci_high", "score", "score_ci_low", "score_ci_high", "score_anchor_ratio", "score_note",
           "fixed_price_ratio", "fixed_price_ratio_ci_low", "fixed_price_ratio_ci_high",
           "fuel_vs_thermal_blind_dp_pct", "reference", "charge_sustaining", "net_energy_ratio",
           "soc_correction_l_per_100km", "miss_correction_l_per_100km", "missed_wheel_energy_kwh", "soc_initial",
           "soc_final", "max_motor_temp_c", "heat_index_max", "derated_s", "cutoff_s", "safety_cost_s",
           "trace_miss_max_mps", "frontier_note")
"""Columns of ``results.csv`` and ``results.json``, in order."""

OVERALL = "all"
"""Cycle and scenario of a seed family's row over every cycle × scenario."""
FUEL_DENSITY_G_PER_L = 1000.0 * paper_bus().engine.fuel_density_kg_per_l

MD_HEAD = ("cycle", "scenario", "strategy", "fuel L/100 km", "corrected L/100 km", "frontier ratio", "score",
           "overheat share of cost", "fixed-price ratio", "vs dp (thermal-blind)", "J1711 charge-sustaining",
           "SOC start → end", "max motor °C", "heat index max", "derated s", "cutoff s", "safety cost s",
           "missed kWh")

EXPLANATION = (
    "*frontier ratio*: the run's cost (fuel + missed wheel energy at the miss price + overheat terms, no "
    "battery price; g) over the thermal optimum's cost at the same final SOC (its frontier, linearly "
    "interpolated): 1 is the optimum. *score*: the normalised score, 100 · (r0 − r) / (r0 − 1) with r the frontier "
    f"ratio and r0 {ANCHOR}'s on the same cycle and scenario: 0 = {ANCHOR}, 100 = the thermal optimum, never "
    f"clipped; marked ill-conditioned (and left out of aggregates) where r0 − 1 < {ILL_CONDITIONED_BELOW}. "
    "*overheat share of cost*: the overheat terms' share of the cost (the rest is fuel and missed wheel energy; "
    "*corrected L/100 km* is the fuel at equal charge and service on its own). *fixed-price ratio*: corrected fuel "
    f"(battery energy at the fixed price) over the {REFERENCE} run's. *vs dp (thermal-blind)*: corrected fuel as a "
    "percentage of `dp`'s, whose plan holds the thermal state at its start (labelled thermal-blind everywhere). "
    "*J1711*: SAE J1711 charge-sustaining test, |net battery energy| ≤ 1 % of the fuel energy; in brackets the signed "
    "ratio (positive: the battery ends with less energy). *safety cost s*: the episode's safety cost, Σ "
    "`info[\"cost\"]`, the seconds of lost motor capability (docs/tasks.md). See docs/metrics.md.")


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return "" if v is None else str(v)


def write_results(out: Path, rows: list[dict], wall_s: float, notes: Sequence[str] = ()) -> None:
    """Write the four files of ``rows`` (run rows, then family rows) into ``out``; ``notes``: extra lines for
    ``results.md`` (e.g. that the reference was added). Fills each row's normalised score (:mod:`.score`) and
    ``overheat_g`` first."""
    add_score_columns(rows)
    for r in rows:
        r["overheat_g"] = overheat_g(r)
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows([COLUMNS, *([_fmt(r.get(c)) for c in COLUMNS] for r in rows)])
    atomic_write_text(out / "results.csv", buf.getvalue())
    clean = [{c: jsonable(r.get(c)) for c in COLUMNS} for r in rows]
    atomic_write_json(out / "results.json", {"columns": list(COLUMNS), "rows": clean, "notes": list(notes)})
    atomic_write_json(out / "timings.json", {"total_wall_s": wall_s, "runs": [
        {"cycle": r["cycle"], "scenario": r["scenario"], "strategy": r["strategy"], "wall_s": r.get("wall_s")}
        for r in rows if not is_family_row(r)]})
    atomic_write_text(out / "results.md", markdown(rows, notes))


def overheat_g(r: dict) -> float | None:
    """The overheat terms of a run's cost (g): ``cost_g`` less the fuel and the missed wheel energy at its price."""
    need = ("cost_g", "fuel_g", "miss_correction_l_per_100km", "distance_km")
    if is_family_row(r) or any(r.get(k) is None for k in need):
        return None
    miss_g = r["miss_correction_l_per_100km"] * r["distance_km"] / 100.0 * FUEL_DENSITY_G_PER_L
    return max(0.0, float(r["cost_g"]) - float(r["fuel_g"]) - miss_g)


def _score_cell(r: dict) -> str:
    text = score_text(r.get("score"), r.get("score_ci_low"), r.get("score_ci_high"))
    return f"{text} (ill-cond.)" if (r.get("score_note") or "").startswith(ILL_CONDITIONED) else text


def ratio_text(r: dict, key: str) -> str:
    """The ratio ``key`` of a row to 3 decimals, with its interval in brackets if it has one; "-" if it has none."""
    v = r.get(key)
    if v is None:
        return "-"
    low, high = r.get(f"{key}_ci_low"), r.get(f"{key}_ci_high")
    return f"{v:.3f} [{low:.3f}, {high:.3f}]" if low is not None and high is not None else f"{v:.3f}"


def _j1711_cell(r: dict) -> str:
    if is_family_row(r):
        return f"{r.get('charge_sustaining_runs', 0)}/{r.get('runs', 0)} runs"
    ratio = r.get("net_energy_ratio")
    flag = "yes" if r.get("charge_sustaining") else "no"
    return flag if ratio is None else f"{flag} ({100.0 * ratio:+.2f} %)"


def _run_line(r: dict) -> list[str]:
    pct, heat = r.get("fuel_vs_thermal_blind_dp_pct"), r.get("overheat_g")
    return [r["cycle"], r["scenario"], display_name(r["strategy"]), f"{r['fuel_l_per_100km']:.2f}",
            f"{r['fuel_corrected_l_per_100km']:.2f}", ratio_text(r, "frontier_ratio"), _score_cell(r),
            "-" if heat is None or not r.get("cost_g") else f"{100.0 * heat / r['cost_g']:.0f} %",
            ratio_text(r, "fixed_price_ratio"), f"{pct:.1f} %" if pct is not None else "-", _j1711_cell(r),
            f"{r['soc_initial']:.3f} → {r['soc_final']:.3f}", f"{r['max_motor_temp_c']:.1f}",
            f"{r['heat_index_max']:.2f}", f"{r['derated_s']:.0f}", f"{r['cutoff_s']:.0f}",
            f"{r['safety_cost_s']:.0f}" if r.get("safety_cost_s") is not None else "-",
            f"{r['missed_wheel_energy_kwh']:.3f}"]


def _family_line(r: dict) -> list[str]:
    fuel = r.get("fuel_corrected_l_per_100km")
    return [r["cycle"], r["scenario"], f"**{r['strategy']}** (IQM of {r['seeds']} seeds)", "-",
            f"{fuel:.2f}" if fuel is not None else "-", ratio_text(r, "frontier_ratio"), _score_cell(r), "-",
            ratio_text(r, "fixed_price_ratio"), "-", _j1711_cell(r), "-", "-", "-", "-", "-", "-", "-"]


def _table(head: Sequence[str], lines: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)] + ["| " + " | ".join(x) + " |" for x in lines]


def markdown(rows: list[dict], notes: Sequence[str] = ()) -> str:
    """``results.md``: the table, the families over every cycle × scenario, the notes."""
    shown = [r for r in rows if r.get("family") is None or (is_family_row(r) and r["cycle"] != OVERALL)]
    lines = [_family_line(r) if is_family_row(r) else _run_line(r) for r in shown]
    md = _table(MD_HEAD, lines)
    overall = [r for r in rows if is_family_row(r) and r["cycle"] == OVERALL]
    if overall:
        md += ["", f"Seed families over every cycle × scenario (IQM over seeds and cycles × scenarios, "
                   f"{100 * CONFIDENCE:.0f} % stratified bootstrap interval):", ""]
        md += _table(("family", "seeds", "runs", "frontier ratio", "score", "fixed-price ratio",
                      "J1711 charge-sustaining"),
                     [[r["strategy"], str(r["seeds"]), str(r["runs"]), ratio_text(r, "frontier_ratio"), _score_cell(r),
                       ratio_text(r, "fixed_price_ratio"), _j1711_cell(r)] for r in overall])
    md += _score_summary(rows)
    md += ["", *_reference_lines(rows), *_heat_value_lines(rows), *_track_lines(rows), "", EXPLANATION]
    if any(is_family_row(r) for r in rows):
        md += ["", f"Seed families: IQM over the seeds with its {100 * CONFIDENCE:.0f} % bootstrap interval in "
                   "brackets; each seed's row is in results.csv and results.json (column `family`)."]
    missing: dict[str, list[str]] = {}  # note -> the rows it concerns (a family's members: on the family's row)
    for r in shown:
        if r.get("frontier_note"):
            missing.setdefault(r["frontier_note"], []).append(
                f"{r['cycle']} / {r['scenario']} / {display_name(r['strategy'])}")
    if missing:
        md += ["", "No frontier ratio:", ""]
        md += [f"* {'every row' if len(where) == len(shown) else ', '.join(where)}: {note}"
               for note, where in missing.items()]
    if notes:
        md += ["", *notes]
    return "\n".join(md) + "\n"


def _score_summary(rows: list[dict]) -> list[str]:
    """The score of each strategy over every cycle × scenario, where there are several."""
    aggs = strategy_aggregates(rows)
    if not aggs or max(a["episodes"] for a in aggs) < 2 or all(a["score"] is None for a in aggs):
        return []
    lines = [[display_name(a["strategy"]), str(a["episodes"]),
              score_text(a["score"], a["score_ci_low"], a["score_ci_high"]), str(a["excluded"])] for a in aggs]
    return ["", "Normalised score over every cycle × scenario (IQM; with seeds to resample, its "
                f"{100 * CONFIDENCE:.0f} % stratified bootstrap interval in brackets; a deterministic strategy has one "
                "run per cycle × scenario and no interval):", "",
            *_table(("strategy", "cycles × scenarios", "score", "left out"), lines)]


def _heat_value_lines(rows: list[dict]) -> list[str]:
    """The value of knowing the heat where ``dp`` ran: its frontier ratio, the thermal-blind plan driven on the thermal
    physics over the optimum (1.000: knowing the heat is worth nothing there)."""
    values = [f"{r['cycle']} / {r['scenario']} {r['frontier_ratio']:.3f}" for r in rows
              if r.get("strategy") == BLIND_DP and r.get("family") is None and r.get("frontier_ratio") is not None]
    if not values:
        return []
    return ["", f"The value of knowing the heat (`{BLIND_DP}` ÷ `{REFERENCE}`, the thermal-blind plan driven on the "
                f"thermal physics over the optimum, at equal charge): {', '.join(values)}."]


def _track_lines(rows: list[dict]) -> list[str]:
    """The track of each learned row or seed family (docs/training.md, *Two tracks*): *guided* where its training
    imitates a strategy (its settings' ``imitate``), else *RL* (the env's reward alone)."""
    tracks: dict[str, str] = {}
    for r in rows:
        settings = r.get("strategy_settings") or {}
        if "imitate" in settings and not is_family_row(r):  # a family's members: under the family's name
            teacher = settings["imitate"]
            tracks.setdefault(r.get("family") or display_name(r["strategy"]),
                              f"guided (its training imitates `{teacher}`)" if teacher else "RL")
    if not tracks:
        return []
    return ["", "Learned rows by track (*RL*: the env's reward alone; *guided*: a strategy's actions or costs in "
                "training; docs/training.md, *Two tracks*): "
                + ", ".join(f"`{name}` {track}" for name, track in tracks.items()) + "."]


def _reference_lines(rows: list[dict]) -> list[str]:
    refs: dict[str, dict[str, None]] = {}  # reference -> the cycles / scenarios it serves, in order
    for r in rows:
        if r.get("reference") and r["cycle"] != OVERALL:
            refs.setdefault(r["reference"], {})[f"{r['cycle']} / {r['scenario']}"] = None
    if len(refs) == 1:
        return [f"Reference of both ratios (1.000): {next(iter(refs))}."]
    return ["Reference of both ratios (1.000), per cycle / scenario:", ""] + [
        f"* {', '.join(where)}: {ref}" for ref, where in refs.items()]
