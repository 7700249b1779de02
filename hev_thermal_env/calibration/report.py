"""The residual table: each target (:data:`~hev_thermal_env.paper.figures.CALIBRATION_TARGETS`), the paper, ours
(calibrated network), ours (the paper's equations), verdicts; measured by :func:`hev_thermal_env.paper.measure.measure`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import yaml

from ..paper.measure import Baseline, measure, sustained_speeds
from ..physics import paper_bus
from ..physics.thermal import ThermalParams
from . import fit as F


def _fmt(x: float, unit: str) -> str:
    if x is None or x != x:
        return "-"
    if x in (float("inf"), float("-inf")):
        return "never"
    if unit == "-":
        return f"{x:.3f}"
    return f"{x:.1f}" if unit == "s" and abs(x) >= 10.0 else f"{x:.2f}"


def _paper(row: dict[str, Any]) -> str:
    """The paper's value and tolerance of a residual row, in the row's unit."""
    if row["kind"] == "max":
        return f"≤ {row['tol']:g}"
    return f"{row['paper']:g} ± {row['tol'] * row['paper'] if row['kind'] == 'rel' else row['tol']:.3g}"


def build(values: dict[str, float], stages: list[F.Stage] | None = None) -> dict[str, Any]:
    """Measure every target with the network and with the paper's equations, both with ``values``."""
    net = F.with_values(paper_bus(), values)
    eqs = net.with_thermal_model("paper_eqs")
    base = Baseline(net)
    m_net = measure(net, base, hwfet=True)
    m_eqs = measure(eqs, base, hwfet=True)
    rows = []
    for t in F.TARGETS:
        a, b = m_net["values"][t.name], m_eqs["values"][t.name]
        rows.append({"name": t.name, "figure": t.figure, "description": t.description, "unit": t.unit,
                     "paper": t.paper, "tol": t.tol, "kind": t.kind, "network": a, "paper_eqs": b,
                     "difference": a - t.paper, "residual": t.residual(a), "met": t.within(a),
                     "paper_eqs_residual": t.residual(b), "paper_eqs_met": t.within(b)})
    corrected = {c: {"without": base.runs[c]["fuel_corrected_l100"],
                     "network": m_net[c]["fuel_corrected_l100"], "paper_eqs": m_eqs[c]["fuel_corrected_l100"]}
                 for c in ("udds", "beijing", "hwfet")}
    bounds = F.fitted_fields()
    return {
        "values": dict(values),
        "bounds": {k: list(bounds[k]) for k in values},
        "start": {k: F.START[k] for k in values},
        "rows": rows,
        "met": sum(r["met"] for r in rows), "n_targets": len(rows),
        "cost": sum(r["residual"] ** 2 for r in rows),
        "network": {k: v for k, v in m_net.items() if k != "values"},
        "paper_eqs": {k: v for k, v in m_eqs.items() if k != "values"},
        "baseline": {"runs": base.runs, "accel_off_s": base.accel_off_s},
        "fuel_corrected_l100": corrected,
        "sustained_speeds_kmh": sustained_speeds(net),
        "stages": [dataclasses.asdict(s) for s in (stages or [])],
    }


def residuals_markdown(report: dict[str, Any]) -> str:
    lines = ["# Thermal model calibration: residuals", "",
             "Written by `python -m hev_thermal_env.calibration --out DIR`. Rule strategy (ADVISOR's parallel "
             "electric assist), ambient and motor at 20 °C, coolant on; Table 3 with the coolant closed. "
             "\"network\": the calibrated default of `paper_bus`; \"paper's eqs\": the paper's one-node model "
             "as written (eqs 1-7) with the same eq 10 closures. Residual r in tolerances; |r| ≤ 1 meets the "
             "target.", "",
             "| target | figure | paper | ours: network | ours: paper's eqs | difference (network) | r (network) | "
             "verdict: network / paper's eqs |",
             "|---|---|---|---|---|---|---|---|"]
    for r in report["rows"]:
        verdict = "met" if r["met"] else "**not met**"
        verdict_eqs = "met" if r["paper_eqs_met"] else "not met"
        lines.append(f"| {r['description']} ({r['unit']}) | {r['figure']} | {_paper(r)} | "
                     f"{_fmt(r['network'], r['unit'])} | {_fmt(r['paper_eqs'], r['unit'])} | "
                     f"{_fmt(r['difference'], r['unit'])} | {r['residual']:+.2f} | {verdict} / {verdict_eqs} |")
    n, e, sp, c = report["network"], report["paper_eqs"], report["sustained_speeds_kmh"], report["fuel_corrected_l100"]
    u, b = n["udds"], n["beijing"]
    met_eqs = sum(r["paper_eqs_met"] for r in report["rows"])
    lines += ["", f"{report['met']} of {report['n_targets']} targets met (network; cost Σr² = {report['cost']:.2f}), "
              f"{met_eqs} with the paper's equations as written. A heat index that never leaves 0 meets the "
              "\"back to 0\" row trivially.",
              "", "## Beside the targets", "",
              "| quantity | network | paper's eqs |", "|---|---|---|"]
    for cyc in ("udds", "hwfet", "beijing"):
        a, z = n[cyc], e[cyc]
        lines.append(f"| {cyc}: motor temperature peak / last 300 s mean (°C) | {a['temp_peak_c']:.1f} / "
                     f"{a['temp_last300_c']:.1f} | {z['temp_peak_c']:.1f} / {z['temp_last300_c']:.1f} |")
        lines.append(f"| {cyc}: heat index first > 0 (s) / peak | {_fmt(a['hi_onset_s'], 's')} / {a['hi_peak']:.3f} | "
                     f"{_fmt(z['hi_onset_s'], 's')} / {z['hi_peak']:.3f} |")
        lines.append(f"| {cyc}: corrected fuel with − without thermal model (L/100 km) | "
                     f"{c[cyc]['network'] - c[cyc]['without']:+.3f} | {c[cyc]['paper_eqs'] - c[cyc]['without']:+.3f} |")
    lines += [f"| beijing: motor temperature after warm-up min / max (°C), warm at | {b['temp_warm_min_c']:.1f} / "
              f"{b['temp_warm_max_c']:.1f}, {b['warm_up_s']:.0f} s | {e['beijing']['temp_warm_min_c']:.1f} / "
              f"{e['beijing']['temp_warm_max_c']:.1f} |",
              f"| udds: coolant peak (°C) | {u['coolant_peak_c']:.1f} | (perfect radiator) |",
              f"| Table 3: 0-60 km/h at 30 / 50 °C start (s) | {n['accel']['accel_30c_s']:.2f} / "
              f"{n['accel']['accel_50c_s']:.2f} | {e['accel']['accel_30c_s']:.2f} / {e['accel']['accel_50c_s']:.2f} |",
              f"| Table 3: top speed off / on (km/h) | {sp['top_speed_off_kmh']:.2f} / {sp['top_speed_on_kmh']:.2f} | "
              f"same |",
              f"| Table 3: 4 % grade speed off / on (km/h) | {sp['grade_speed_off_kmh']:.2f} / "
              f"{sp['grade_speed_on_kmh']:.2f} | same |", "",
              "## Fitted parameters", "", "| parameter | fitted | bounds | start |", "|---|---|---|---|"]
    for k, v in report["values"].items():
        lo, hi = report["bounds"][k]
        lines.append(f"| `{k}` | {v:g} | [{lo:g}, {hi:g}] | {report['start'][k]:g} |")
    if report["stages"]:
        lines += ["", "| stage | parameters | cost before → after | runs | wall (s) |", "|---|---|---|---|---|"]
        for s in report["stages"]:
            lines.append(f"| {s['name']} | {len(s['params'])} | {s['cost_start']:.3f} → {s['cost']:.3f} | "
                         f"{s['evaluations']} | {s['wall_s']:.0f} |")
    return "\n".join(lines) + "\n"


def params_yaml(values: dict[str, float]) -> str:
    header = ("# Fitted thermal parameters of paper_bus, written by python -m hev_thermal_env.calibration.\n"
              "# VehicleConfig.from_yaml(this file) is paper_bus with these values;\n"
              "# ThermalParams's defaults hold them (--write-defaults writes them there).\n")
    fields = [f.name for f in dataclasses.fields(ThermalParams)]
    ordered = {k: values[k] for k in fields if k in values}
    return header + yaml.safe_dump({"thermal": ordered}, sort_keys=False)
