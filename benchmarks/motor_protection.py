#!/usr/bin/env python
"""Motor protection in numbers: what heat, derating and cut-off cost each strategy, and where the motor's heat
comes from.

Two tables, every run through the public evaluation API (``run_strategy`` of ``get_strategy(name)``):

1. ``hot`` scenario, every built-in cycle: ``engine_only``, ``rule``, ``ecms``, ``ecms_thermal``, ``dp_thermal`` (the
   optimum, the yardstick's reference) and ``conventional`` where the package has it. Per run: the yardstick cost
   (g), the corrected fuel (L/100 km), the frontier ratio, the final SOC, the seconds in cut-off, derated (heat
   index > 0) and, where the state has it, with the winding protection tripped; the share of the motor's heat made
   while regenerating (``motor_heat_w`` summed over the steps with ``motor_torque_nm`` < 0 and
   ``shaft_torque_demand_nm`` < 0, over its sum on every step); and whether the optimum costs no more than
   ``engine_only``.
2. ``summer``, ``hilly``, ``full_bus``, ``hot`` on ``hwfet``, ``udds``, ``beijing``: ``ecms`` against ``ecms_thermal``
   (fuel, derated and cut-off seconds): what thermal awareness is worth.

The script imports only the package (never a file beside it), so it runs on any checkout of the project: run it
with that checkout on ``PYTHONPATH``; the JSON records which tree it measured (commit, state columns)::

    PYTHONPATH=. python benchmarks/motor_protection.py --out benchmarks/results/motor_protection_v1.json
    PYTHONPATH=. python benchmarks/motor_protection.py --quick --out /tmp/motor_protection_quick.json

``dp_thermal`` solves its plan per cycle and scenario (minutes each, unless the plan is in the plan cache); the
other runs take about a second. ``--jobs N`` runs cells in N processes (the slow ones first).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

HOT = "hot"
HOT_STRATEGIES = ("engine_only", "rule", "ecms", "ecms_thermal", "dp_thermal")
OPTIONAL_STRATEGIES = ("conventional",)  # a reference row, where the package registers it
OPTIMUM, ENGINE_ONLY = "dp_thermal", "engine_only"
AWARENESS_SCENARIOS = ("summer", "hilly", "full_bus", "hot")
AWARENESS_CYCLES = ("hwfet", "udds", "beijing")
AWARENESS_STRATEGIES = ("ecms", "ecms_thermal")
QUICK_CYCLES = ("hwfet",)
QUICK_SCENARIOS = ("summer", "hot")
QUICK_OPTIONS = {OPTIMUM: {"grid_scale": 0.5}}  # a coarser optimum: a check that everything runs, not a figure
SUMMARY_FIELDS = ("cost_g", "fuel_g", "fuel_l_per_100km", "fuel_corrected_l_per_100km", "distance_km", "duration_s",
                  "soc_initial", "soc_final", "charge_sustaining", "missed_wheel_energy_kwh", "max_motor_temp_c",
                  "heat_index_max", "derated_s", "cutoff_s", "engine_on_s", "wall_s", "plan_s", "thermal_aware")
NOT_MEASURED_HERE = ("fuel_vs_thermal_blind_dp_pct",)  # needs the thermal-blind dp, not run here
#: Expected seconds of a run per second of cycle, for the order of the work (the optimum searches).
SECONDS_PER_STEP = {OPTIMUM: 0.06}
OTHER_SECONDS_PER_STEP = 1e-3


def regen_heat(trace: dict[str, np.ndarray], dt_s: float) -> dict[str, float | None]:
    """The motor's heat (J) on every step and on the regenerating steps (motor torque < 0 while the shaft asks for
    braking, shaft demand < 0), their ratio (None when the motor made no heat), and the electrical energy the motor
    returned while regenerating (kWh)."""
    heat = np.asarray(trace["motor_heat_w"], dtype=float)
    regen = (np.asarray(trace["motor_torque_nm"]) < 0.0) & (np.asarray(trace["shaft_torque_demand_nm"]) < 0.0)
    total_j = float(heat.sum() * dt_s)
    regen_j = float(heat[regen].sum() * dt_s)
    elec = np.asarray(trace["motor_elec_power_w"], dtype=float)
    return {"motor_heat_j": total_j, "regen_heat_j": regen_j,
            "regen_heat_share": regen_j / total_j if total_j > 0.0 else None,
            "regen_s": float(regen.sum() * dt_s), "regen_elec_kwh": float(-elec[regen].sum() * dt_s / 3.6e6)}


def cell_row(summary: dict[str, Any], trace: dict[str, np.ndarray], settings: dict[str, Any]) -> dict[str, Any]:
    """One run's row: the summary's fields, the protection's seconds, the regeneration's heat and the settings."""
    steps = len(trace["fuel_g"])
    dt_s = float(summary["duration_s"]) / steps if steps else 1.0
    row = {k: summary.get(k) for k in SUMMARY_FIELDS}
    row["winding_trip_s"] = (float((np.asarray(trace["winding_trip"]) > 0.0).sum() * dt_s)
                             if "winding_trip" in trace else None)
    row["max_winding_temp_c"] = float(np.max(trace["winding_temp_c"])) if "winding_temp_c" in trace else None
    row.update(regen_heat(trace, dt_s))
    row["strategy_settings"] = settings
    return row


def run_cell(cell: tuple[str, str, str], options: dict[str, dict]) -> dict[str, Any]:
    """Run one (scenario, cycle, strategy) and return its row (the optimum's frontier kept for the yardstick)."""
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.runner import run_strategy

    scenario, cycle, strategy = cell
    res = run_strategy(get_strategy(strategy, **options.get(strategy, {})), cycle, scenario)
    row = {"scenario": scenario, "cycle": res.summary["cycle"], "strategy": strategy}
    row.update(cell_row(res.summary, res.trace, res.summary.get("strategy_settings") or {}))
    return row


def tree_info() -> dict[str, Any]:
    """Which checkout ran: its commit (if a git tree), the state columns and the env ids it registers."""
    import gymnasium

    import hev_thermal_env
    from hev_thermal_env.physics import core

    root = Path(hev_thermal_env.__file__).resolve().parents[1]
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                                check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = None
    return {"root": str(root), "commit": commit, "state_names": list(core.STATE_NAMES),
            "env_ids": sorted(k for k in gymnasium.registry if k.startswith("HevThermal"))}


def plan_cells(quick: bool) -> tuple[list[tuple[str, str, str]], list[str], list[str]]:
    """The (scenario, cycle, strategy) cells, without repeats; the cycles and strategies of the hot table."""
    import hev_thermal_env
    from hev_thermal_env.agents import list_strategies

    known = set(list_strategies())
    strategies = [s for s in (*HOT_STRATEGIES, *OPTIONAL_STRATEGIES) if s in known]
    cycles = list(QUICK_CYCLES if quick else hev_thermal_env.list_cycles())
    scenarios = QUICK_SCENARIOS if quick else AWARENESS_SCENARIOS
    aware_cycles = QUICK_CYCLES if quick else AWARENESS_CYCLES
    cells = [(HOT, c, s) for c in cycles for s in strategies]
    cells += [(sc, c, s) for sc in scenarios for c in aware_cycles for s in AWARENESS_STRATEGIES]
    return list(dict.fromkeys(cells)), cycles, strategies


def accepted_options(options: dict[str, dict]) -> dict[str, dict]:
    """The options each strategy of this tree accepts (an option the tree's strategy lacks is dropped)."""
    from hev_thermal_env.agents import get_strategy

    kept = {}
    for name, opts in options.items():
        try:
            get_strategy(name, **opts)
            kept[name] = opts
        except ValueError:
            kept[name] = {}
    return kept


def run_cells(cells: list[tuple[str, str, str]], options: dict[str, dict], jobs: int) -> list[dict]:
    """Every cell's row, in the order of ``cells``; ``jobs`` processes (the slowest cells first)."""
    from hev_thermal_env.cycles import load_cycle

    steps = {c: load_cycle(c).n_steps for c in {cell[1] for cell in cells}}
    weight = [SECONDS_PER_STEP.get(s, OTHER_SECONDS_PER_STEP) * steps[c] for _, c, s in cells]
    order = sorted(range(len(cells)), key=lambda i: (-weight[i], i))
    rows: list[Any] = [None] * len(cells)
    with tqdm(total=len(cells), desc="cells", unit="run") as bar:
        if jobs <= 1:
            for i in order:
                bar.set_postfix_str("/".join(cells[i]))
                rows[i] = run_cell(cells[i], options)
                bar.update()
            return rows
        with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(run_cell, cells[i], options): i for i in order}
            for fut in as_completed(futures):
                rows[futures[fut]] = fut.result()
                bar.set_postfix_str("/".join(cells[futures[fut]]))
                bar.update()
    return rows


def add_yardstick(rows: list[dict]) -> None:
    """The benchmark's ratios (frontier ratio against the optimum of the same cycle and scenario) on every row; the
    optimum's frontier then leaves the settings (hundreds of points nobody reads here)."""
    from hev_thermal_env.evaluation.yardstick import add_yardstick_columns

    add_yardstick_columns(rows)
    for r in rows:
        for k in NOT_MEASURED_HERE:
            r.pop(k, None)
        settings = r.get("strategy_settings") or {}
        r["strategy_settings"] = {k: v for k, v in settings.items() if k != "frontier"}


HOT_KEYS = ("cost_g", "fuel_corrected_l_per_100km", "frontier_ratio", "soc_final", "cutoff_s", "derated_s",
            "winding_trip_s", "regen_heat_share", "max_motor_temp_c", "max_winding_temp_c")
AWARE_KEYS = ("fuel_g", "fuel_l_per_100km", "fuel_corrected_l_per_100km", "cost_g", "soc_final", "derated_s",
              "cutoff_s", "winding_trip_s", "regen_heat_share")


def hot_table(rows: list[dict], cycles: list[str], strategies: list[str]) -> dict[str, Any]:
    """Per cycle of the hot scenario: each strategy's figures, and whether the optimum costs ≤ ``engine_only`` at
    equal charge (``engine_only``'s frontier ratio ≥ 1 − 0.1 %; it ends with less charge than the optimum, having
    regenerated nothing, so the raw costs compare unequal charge and are kept beside it)."""
    by = {(r["scenario"], r["cycle"], r["strategy"]): r for r in rows}
    table = {}
    for c in cycles:
        runs = {s: {k: by[(HOT, c, s)].get(k) for k in HOT_KEYS} for s in strategies if (HOT, c, s) in by}
        opt, eng = runs.get(OPTIMUM), runs.get(ENGINE_ONLY)
        le = None if opt is None or eng is None else bool(opt["cost_g"] <= eng["cost_g"])
        ratio = None if eng is None else eng.get("frontier_ratio")
        table[c] = {"runs": runs, "optimum_le_engine_only_at_equal_charge": None if ratio is None else
                    bool(ratio >= 1.0 - 1e-3), "optimum_raw_cost_le_engine_only": le}
    return table


def awareness_table(rows: list[dict]) -> list[dict[str, Any]]:
    """``ecms`` against ``ecms_thermal`` per scenario and cycle, with the fuel change in percent."""
    by = {(r["scenario"], r["cycle"], r["strategy"]): r for r in rows}
    out = []
    for sc, c in dict.fromkeys((r["scenario"], r["cycle"]) for r in rows):
        if not all((sc, c, s) in by for s in AWARENESS_STRATEGIES):
            continue
        blind, aware = (by[(sc, c, s)] for s in AWARENESS_STRATEGIES)
        pct = (100.0 * (aware["fuel_corrected_l_per_100km"] / blind["fuel_corrected_l_per_100km"] - 1.0)
               if blind["fuel_corrected_l_per_100km"] else None)
        out.append({"scenario": sc, "cycle": c, "ecms": {k: blind.get(k) for k in AWARE_KEYS},
                    "ecms_thermal": {k: aware.get(k) for k in AWARE_KEYS},
                    "corrected_fuel_change_pct": pct})
    return out


def _f(x: Any, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def markdown(result: dict[str, Any]) -> str:
    """Both tables as Markdown text."""
    lines = ["| cycle | strategy | cost g | corr. L/100km | ratio | SOC end | cut-off s | derated s | trip s | "
             "regen heat share |", "|" + "---|" * 10]
    for c, t in result["hot"].items():
        for s, r in t["runs"].items():
            lines.append(f"| {c} | {s} | {_f(r['cost_g'], '.1f')} | {_f(r['fuel_corrected_l_per_100km'], '.2f')} | "
                         f"{_f(r['frontier_ratio'], '.3f')} | {_f(r['soc_final'], '.3f')} | {_f(r['cutoff_s'], '.0f')} "
                         f"| {_f(r['derated_s'], '.0f')} | {_f(r['winding_trip_s'], '.0f')} | "
                         f"{_f(r['regen_heat_share'], '.2f')} |")
        lines.append(f"| {c} | optimum ≤ engine_only at equal charge | "
                     f"{t['optimum_le_engine_only_at_equal_charge']} | | | | | | | |")
    lines += ["", "| scenario | cycle | ecms corr. L/100km | ecms_thermal | change % | derated s (ecms/thermal) | "
              "cut-off s (ecms/thermal) |", "|" + "---|" * 7]
    for a in result["thermal_awareness"]:
        b, t = a["ecms"], a["ecms_thermal"]
        lines.append(f"| {a['scenario']} | {a['cycle']} | {_f(b['fuel_corrected_l_per_100km'], '.2f')} | "
                     f"{_f(t['fuel_corrected_l_per_100km'], '.2f')} | {_f(a['corrected_fuel_change_pct'], '+.1f')} | "
                     f"{_f(b['derated_s'], '.0f')}/{_f(t['derated_s'], '.0f')} | "
                     f"{_f(b['cutoff_s'], '.0f')}/{_f(t['cutoff_s'], '.0f')} |")
    return "\n".join(lines) + "\n"


def write_json(path: Path, data: dict[str, Any]) -> None:
    """The package's atomic writer where it has one, else a plain write."""
    try:
        from hev_thermal_env.io import atomic_write_json
    except ImportError:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=2) + "\n")
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(path, data)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="the JSON file to write")
    ap.add_argument("--quick", action="store_true",
                    help=f"a short check: {', '.join(QUICK_CYCLES)}; scenarios {', '.join(QUICK_SCENARIOS)}; "
                         "a coarser optimum")
    ap.add_argument("--jobs", type=int, default=1, help="processes over the cells (default 1)")
    args = ap.parse_args(argv)
    from hev_thermal_env.evaluation.runner import jsonable

    t0 = time.perf_counter()
    cells, cycles, strategies = plan_cells(args.quick)
    options = accepted_options(QUICK_OPTIONS) if args.quick else {}
    rows = run_cells(cells, options, max(1, args.jobs))
    add_yardstick(rows)
    result = {"tree": tree_info(), "quick": args.quick, "options": options, "python": sys.version.split()[0],
              "cpu_count": os.cpu_count(), "jobs": args.jobs, "wall_s": time.perf_counter() - t0,
              "hot": hot_table(rows, cycles, strategies), "thermal_awareness": awareness_table(rows), "rows": rows}
    result = jsonable(result)
    write_json(args.out, result)
    print(markdown(result))
    print(f"wrote {args.out} ({len(rows)} runs, {result['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
