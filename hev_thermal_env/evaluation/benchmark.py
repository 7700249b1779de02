"""The benchmark: every strategy on every cycle and scenario, one table and plots.

``python evaluate.py benchmark --out DIR`` writes ``results.csv``, ``results.json``, ``results.md``
(one row per cycle × scenario × strategy, with fuel relative to DP on the same cycle and scenario)
and PNGs: per cycle and scenario, speed / missed wheel energy / SOC / motor temperature / heat
index / split over time for every strategy on shared axes (:mod:`.plots`), and a dot chart of
corrected fuel relative to DP, one row of panels per scenario (:mod:`.fuel_chart`).

Independent runs are spread over processes or Ray tasks (:mod:`.executors`); each run is
deterministic (fixed seed, no shared state), so the results equal a serial run's, byte for byte:
wall times go to ``timings.json``, not into the results. Every file is written atomically.
"""

from __future__ import annotations

import csv
import io
import os
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import ImplausibleCycleWarning, load_cycle
from hev_thermal_env.envs.render import SPLIT_INFO_KEY
from hev_thermal_env.io import atomic_write_json, atomic_write_text, check_writable_dir
from hev_thermal_env.scenarios import get_scenario

from .executors import make_executor
from .plots import plot_benchmark
from .runner import run_strategy

DEFAULT_CYCLES = ("hwfet", "beijing")
DEFAULT_SCENARIOS = ("paper",)
DEFAULT_STRATEGIES = ("engine_only", "rule", "ecms", "aecms", "ecms_thermal", "dp", "ppo")

COLUMNS = ("cycle", "scenario", "strategy", "distance_km", "fuel_g", "fuel_l_per_100km", "fuel_corrected_l_per_100km",
           "fuel_vs_dp_pct", "soc_correction_l_per_100km", "miss_correction_l_per_100km", "missed_wheel_energy_kwh",
           "soc_initial", "soc_final", "max_motor_temp_c", "heat_index_max", "derated_s", "cutoff_s",
           "trace_miss_max_mps")
TRACE_KEYS = ("time_s", "speed_mps", "cycle_speed_mps", "soc", "motor_temp_c", "heat_index", SPLIT_INFO_KEY,
              "motor_torque_nm", "engine_torque_nm", "fuel_g", "missed_wheel_energy_j", "motor_cutoff",
              "shaft_torque_demand_nm")


def _run_one(task: tuple[str, str, str, dict]) -> tuple[dict, dict]:
    cycle, scenario, strategy, options = task
    with warnings.catch_warnings():  # the main process warned about implausible cycle data when validating
        warnings.simplefilter("ignore", ImplausibleCycleWarning)
        cyc = load_cycle(cycle)
    res = run_strategy(get_strategy(strategy, **options.get(strategy, {})), cyc, scenario)
    trace = {k: np.asarray(res.trace[k]) for k in TRACE_KEYS if k in res.trace}
    summary = dict(res.summary)
    summary.update(cycle=cyc.name, scenario=scenario, strategy=strategy)
    return summary, trace


def validate(cycles, strategies, scenarios, out: Path, options: dict | None = None) -> None:
    """Fail before any work on unknown names, strategies that cannot be built (a missing model, an unknown
    option) or an unusable output directory."""
    for c in cycles:
        load_cycle(c)
    for s in scenarios:
        get_scenario(s)
    for s in strategies:
        get_strategy(s, **(options or {}).get(s, {}))
    check_writable_dir(out)


def run_benchmark(out_dir: str | Path, cycles=DEFAULT_CYCLES, strategies=DEFAULT_STRATEGIES,
                  scenarios=DEFAULT_SCENARIOS, *, jobs: int | None = None, options: dict | None = None,
                  progress: bool = True, plots: bool = True, executor: str = "local",
                  address: str | None = None) -> list[dict]:
    """Run every combination, write the result files and plots, return the rows.

    ``executor`` is where the runs happen (:mod:`.executors`): ``local`` processes (``jobs`` of
    them) or ``ray`` tasks (a local Ray runtime of ``jobs`` CPUs, or the cluster at ``address``);
    the files are the same, byte for byte."""
    out = Path(out_dir)
    validate(cycles, strategies, scenarios, out, options)
    options = options or {}
    tasks = [(c, sc, st, options) for c in cycles for sc in scenarios for st in strategies]
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(tasks)))
    runner = make_executor(executor, jobs=jobs, address=address)
    t0 = time.perf_counter()
    with runner:
        results = _run_tasks(tasks, runner, progress)
    rows = [r[0] for r in results]
    traces = {(r[0]["cycle"], r[0]["scenario"], r[0]["strategy"]): r[1] for r in results}
    dp_fuel = {(r["cycle"], r["scenario"]): r["fuel_corrected_l_per_100km"] for r in rows if r["strategy"] == "dp"}
    for r in rows:
        ref = dp_fuel.get((r["cycle"], r["scenario"]))
        r["fuel_vs_dp_pct"] = 100.0 * r["fuel_corrected_l_per_100km"] / ref if ref else None
    out.mkdir(parents=True, exist_ok=True)
    write_results(out, rows, wall_s=time.perf_counter() - t0)
    if plots:
        plot_benchmark(out, rows, traces)
    return rows


def _run_tasks(tasks: list[tuple], executor, progress: bool) -> list[tuple[dict, dict]]:
    """``_run_one`` of every task (on ``executor``, see :mod:`.executors`), results in the order of ``tasks``."""
    # slow runs first so that the workers stay busy
    order = sorted(range(len(tasks)), key=lambda i: (0 if tasks[i][2].startswith("dp") else 1, i))
    results: list[Any] = [None] * len(tasks)
    with tqdm(total=len(tasks), desc="benchmark runs", unit="run", disable=not progress) as bar:
        for i, result in executor.map(_run_one, tasks, order):
            results[i] = result
            bar.set_postfix_str(f"{tasks[i][0]}/{tasks[i][1]}/{tasks[i][2]}")
            bar.update()
    return results


def _fmt(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def write_results(out: Path, rows: list[dict], wall_s: float) -> None:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([_fmt(r.get(c)) for c in COLUMNS])
    atomic_write_text(out / "results.csv", buf.getvalue())
    clean = [{c: (r.get(c).item() if isinstance(r.get(c), (np.floating, np.integer)) else r.get(c)) for c in COLUMNS}
             for r in rows]
    atomic_write_json(out / "results.json", {"columns": list(COLUMNS), "rows": clean})
    atomic_write_json(out / "timings.json", {
        "total_wall_s": wall_s,
        "runs": [{"cycle": r["cycle"], "scenario": r["scenario"], "strategy": r["strategy"], "wall_s": r.get("wall_s")}
                 for r in rows]})
    md = ["| cycle | scenario | strategy | fuel L/100 km | corrected L/100 km | vs DP | SOC start → end | "
          "max motor °C | heat index max | derated s | cutoff s | missed kWh |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        vs = f"{r['fuel_vs_dp_pct']:.1f} %" if r.get("fuel_vs_dp_pct") else "-"
        md.append(f"| {r['cycle']} | {r['scenario']} | {r['strategy']} | {r['fuel_l_per_100km']:.2f} | "
                  f"{r['fuel_corrected_l_per_100km']:.2f} | {vs} | {r['soc_initial']:.3f} → {r['soc_final']:.3f} | "
                  f"{r['max_motor_temp_c']:.1f} | {r['heat_index_max']:.2f} | {r['derated_s']:.0f} | "
                  f"{r['cutoff_s']:.0f} | {r['missed_wheel_energy_kwh']:.3f} |")
    md += ["", "Corrected fuel puts strategies on equal service: fuel plus the fuel equivalent of the net battery "
           "energy used and of the missed wheel energy (see README, *Metrics*). \"vs DP\" is corrected fuel "
           "relative to the dynamic-programming optimum on the same cycle and scenario."]
    atomic_write_text(out / "results.md", "\n".join(md) + "\n")
