#!/usr/bin/env python
"""Where does heat bind? The search for thermal tasks on a physics version, and its matrix.

For each candidate condition (a route × ambient × cooling × payload × road) every strategy of :data:`STRATEGIES` is
driven through ``run_strategy`` on the chosen physics (``--physics``). Per run: the yardstick cost (g), corrected fuel
(L/100 km), the frontier ratio against ``dp_thermal``'s frontier, ΔSOC, derated and cut-off seconds, the housing
and winding peaks. ``engine_only`` is the spinning-loss-only run (u = 0: no assist, no regeneration), whose
housing peak shows whether the spinning motor's loss alone holds it above the cut-off's release.

A candidate is a *thermal task* when (docs/tasks.md, *Thermal tasks*):

* knowing the heat pays: the thermal-blind ``dp`` driven on the thermal physics has a frontier ratio ≥ 1.01;
* the optimum is never cut off (``dp_thermal`` cut-off seconds = 0);
* the thermal-aware ECMS is no dearer than its blind twin (``ecms_thermal`` ratio ≤ ``ecms`` ratio);
* the spinning losses alone never cut the motor off (``engine_only``: no cut-off, housing peak below the release);
* the optimum is the yardstick: no strategy's frontier ratio below 0.999 (where the optimum's search falls short of a
  causal strategy, the candidate cannot be scored against it).

``--screen`` first drives the causal strategies alone (``engine_only``, ``ecms``, ``ecms_thermal``: seconds a run)
over a grid of routes, air, cooling and payload (:data:`SCREEN`) and of warm starts on one lap of UDDS
(:data:`SCREEN_WARM`): where is the blind ECMS cut off while the spinning motor is not? The candidates
(:data:`CANDIDATES`) come from it.

Run with the checkout on ``PYTHONPATH``; ``dp_thermal`` takes from seconds to many minutes per candidate::

    PYTHONPATH=. python benchmarks/thermal_tasks.py --screen --out benchmarks/results/thermal_screen_v2.json

    PYTHONPATH=. python benchmarks/thermal_tasks.py --physics 2 --out benchmarks/results/thermal_tasks_v2.json
    PYTHONPATH=. python benchmarks/thermal_tasks.py --physics 1 --out benchmarks/results/thermal_tasks_v1.json
    PYTHONPATH=. python benchmarks/thermal_tasks.py --quick --out /tmp/thermal_tasks_quick.json
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

#: The optimum's guarantee (docs/guarantees.md): no strategy more than 0.1 % below its frontier.
OPTIMUM_SLACK = 0.999
STRATEGIES = ("engine_only", "rule", "ecms", "ecms_thermal", "dp", "dp_thermal")
#: Generated routes for the search: seeds above every training, validation and earlier selection seed.
ROUTE_SEED = 2**31 + 300
HOT_FULL = {"ambient_c": 40.0, "payload_kg": 4500.0}
#: Physics v2's candidates: name, cycle (``NAME*K``: K laps, ``load_cycle``), scenario (its road), and the
#: conditions' changes from the paper's (ambient; motor and coolant starting at ``start_c``, by default the ambient;
#: ``pump``: the pump's flow share; ``fan``). Chosen from the screen (docs/tasks.md, *Where heat binds*): one lap of
#: UDDS, flat or over the hills, with a full bus an hour into service (the motor still warm) on a hot day with a weak
#: loop, where the blind ECMS is cut off or comes within 2 K of it and the spinning motor stays below its release. An
#: hour of service from a cold start (two or three laps) was searched too, but the optimum did not finish.
CANDIDATES = (
    ("udds-40c-full", "udds", "paper", {**HOT_FULL}),
    ("udds-40c-full-pump10-warm55", "udds", "paper", {**HOT_FULL, "pump": 0.1, "start_c": 55.0}),
    ("udds-hilly-35c-full-pump10-warm58", "udds", "hilly",
     {**HOT_FULL, "ambient_c": 35.0, "pump": 0.1, "start_c": 58.0}),
    ("udds-hilly-40c-full-pump20-nofan-warm58", "udds", "hilly",
     {**HOT_FULL, "pump": 0.2, "fan": False, "start_c": 58.0}),
    ("udds-hilly-40c-full-pump10-warm55", "udds", "hilly", {**HOT_FULL, "pump": 0.1, "start_c": 55.0}),
    ("udds-hilly-40c-full-pump30-nofan-warm58", "udds", "hilly",
     {**HOT_FULL, "pump": 0.3, "fan": False, "start_c": 58.0}),
    ("udds-hilly-40c-full-pump30-nofan-warm55", "udds", "hilly",
     {**HOT_FULL, "pump": 0.3, "fan": False, "start_c": 55.0}),
)
#: Physics v1's thermal tasks, in their own scenarios (the matrix before): the optimum is the task's stored reference
#: (its run and its frontier, sampled), not solved again.
V1_TASKS = (
    ("udds-hot-v1", "udds", "hot", None),
    ("hilly-v1", "udds", "hilly", None),
    ("full-bus-v1", "udds", "full_bus", None),
    ("summer-v1", "udds", "summer", None),
)
#: The screen: the causal strategies alone (seconds a run) over routes × air × cooling (pump share, fan) × payload,
#: to find where the blind ECMS is cut off and the spinning motor is not; the search's candidates come from it.
SCREEN_CYCLES = ("udds*3", "beijing*3", "hwfet*2", f"bus_long:{ROUTE_SEED}", f"bus_hilly:{ROUTE_SEED}",
                 f"bus_mixed:{ROUTE_SEED}")
SCREEN_COOLING = ((1.0, True), (0.5, True), (0.3, True), (0.2, True), (0.15, True), (0.1, True), (1.0, False),
                  (0.3, False), (0.2, False))
SCREEN = tuple((f"{c}|{a:.0f}C|pump{p:.2f}|fan{int(f)}|{m:.0f}kg", c, "paper",
                {"ambient_c": a, "pump": p, "fan": f, "payload_kg": m})
               for c in SCREEN_CYCLES for a in (35.0, 40.0) for p, f in SCREEN_COOLING for m in (0.0, 4500.0)
               if a == 40.0 or (m == 4500.0 and f))
#: ... and one lap of UDDS, flat or over the hills, with a full bus an hour into service: motor and coolant starting
#: warm (55 or 58 °C) in 35 or 40 °C air with a weak loop.
SCREEN_WARM = tuple((f"udds|{scen}|{a:.0f}C|start{w:.0f}|pump{p:.2f}|fan{int(f)}|4500kg", "udds", scen,
                     {"ambient_c": a, "pump": p, "fan": f, "payload_kg": 4500.0, "start_c": w})
                    for scen in ("paper", "hilly") for a in (35.0, 40.0) for w in (55.0, 58.0)
                    for p, f in ((0.1, True), (0.15, True), (0.2, False), (0.3, False)))
SCREEN_STRATEGIES = ("engine_only", "ecms", "ecms_thermal")
QUICK = (("udds-40c-full", "udds", "paper", {**HOT_FULL}),)
QUICK_OPTIONS = {"dp_thermal": {"grid_scale": 0.5}}  # a coarser optimum: a check that everything runs
SUMMARY_FIELDS = ("cost_g", "fuel_g", "fuel_corrected_l_per_100km", "delta_soc", "derated_s", "cutoff_s",
                  "max_motor_temp_c", "safety_cost_s", "missed_wheel_energy_kwh", "wall_s", "plan_s")


def conditions_of(changes: dict[str, Any] | None) -> Any:
    """The candidate's :class:`~hev_thermal_env.physics.Conditions` (None: the scenario's own); a weakened pump is
    :func:`~hev_thermal_env.scenarios.in_service`, the conditions the thermal task's scenario is built from."""
    from hev_thermal_env.physics import Conditions
    from hev_thermal_env.scenarios import in_service
    if changes is None:
        return None
    ambient, pump, payload = changes.get("ambient_c", 20.0), changes.get("pump", 1.0), changes.get("payload_kg", 0.0)
    start, fan = changes.get("start_c", ambient), changes.get("fan", True)
    if pump < 1.0:
        return in_service(ambient, start, pump, fan=fan, payload_kg=payload)
    return Conditions(ambient_temp_c=ambient, initial_motor_temp_c=start, coolant_temp_c=start, coolant="on",
                      coolant_degraded_factor=1.0, payload_kg=payload, fan=fan)


def screen_candidate(candidate: tuple, physics: int) -> dict[str, Any]:
    """The causal strategies on one screen cell: cost, housing peak, derated and cut-off seconds, ΔSOC."""
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation import run_strategy

    name, cycle, scenario, changes = candidate
    cond = conditions_of(changes)
    runs = {}
    for strategy in SCREEN_STRATEGIES:
        s = run_strategy(get_strategy(strategy), cycle, scenario, conditions=cond, physics=physics).summary
        runs[strategy] = {k: s.get(k) for k in ("cost_g", "max_motor_temp_c", "derated_s", "cutoff_s", "delta_soc")}
    return {"name": name, "cycle": cycle, "conditions": changes, "runs": runs,
            "ecms_cut_off": runs["ecms"]["cutoff_s"] > 0, "spinning_cut_off": runs["engine_only"]["cutoff_s"] > 0,
            "ecms_thermal_over_ecms": runs["ecms_thermal"]["cost_g"] / runs["ecms"]["cost_g"]}


def fixed_price_cost_g(trace: dict[str, Any], physics: int) -> float:
    """A run's yardstick cost (fuel + missed energy at its price + overheat terms) at physics version ``physics``'s
    overheat price, plus the battery energy it used at the battery's fixed price (equal charge): how the overheat
    price alone moves a ranking."""
    import numpy as np

    from hev_thermal_env.envs.reward import RewardParams
    from hev_thermal_env.metrics import yardstick_cost_g
    from hev_thermal_env.physics import core, paper_bus

    out = np.column_stack([trace[k] for k in core.OUT_NAMES])
    state = np.column_stack([trace[k] for k in core.STATE_NAMES])
    prices, lhv = RewardParams.for_physics(physics), paper_bus().engine.fuel_lhv_j_per_g
    battery_g = float(np.sum(out[:, core.BATT_CHEM])) * prices.prices.battery_g_per_j(lhv)
    return yardstick_cost_g(out, state, prices, lhv, 1.0) + battery_g


def run_candidate(candidate: tuple, physics: int, quick: bool, threads: int | None = None) -> dict[str, Any]:
    """Every strategy on one candidate; ratios against the candidate's own ``dp_thermal`` frontier."""
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation import run_strategy
    from hev_thermal_env.evaluation.score import Frontier, frontier_ratio

    name, cycle, scenario, changes = candidate
    cond = conditions_of(changes)
    runs: dict[str, dict[str, Any]] = {}
    frontier = None
    stored = physics == 1 and name in {c[0] for c in V1_TASKS}
    if stored:  # the task's stored reference: the optimum's run and frontier (every k-th breakpoint)
        from hev_thermal_env.evaluation.references import load_reference
        episode = load_reference(name)["episodes"][0]
        frontier = Frontier.from_settings({"frontier": episode["frontier"]})
        runs["dp_thermal"] = {**episode["optimum"], "cutoff_s": None, "derated_s": None, "max_motor_temp_c": None,
                              "winding_peak_c": None, "from_reference": True}
    for strategy in reversed(STRATEGIES):  # the optimum first: its frontier is every ratio's reference
        if stored and strategy == "dp_thermal":
            continue
        options = dict(QUICK_OPTIONS.get(strategy, {})) if quick else {}
        if strategy in ("dp", "dp_thermal") and threads is not None:
            options["threads"] = threads
        res = run_strategy(get_strategy(strategy, **options), cycle, scenario, conditions=cond,
                           physics=physics)
        s = res.summary
        row = {k: s.get(k) for k in SUMMARY_FIELDS}
        row["winding_peak_c"] = float(res.trace["winding_temp_c"].max())
        row["fixed_price_cost_g"] = fixed_price_cost_g(res.trace, physics)
        row["fixed_price_cost_g_other_price"] = fixed_price_cost_g(res.trace, 3 - physics)
        if strategy == "dp_thermal":
            frontier = Frontier.from_settings(s.get("strategy_settings"))
        row["frontier_ratio"], row["ratio_note"] = frontier_ratio(s["cost_g"], s["soc_final"], frontier)
        runs[strategy] = row
    ratio = {k: r["frontier_ratio"] for k, r in runs.items()}
    from hev_thermal_env.physics import paper_bus
    release = paper_bus(physics=physics).thermal.cutoff_release_temp_c
    checks = {
        "knowing_heat_pays": ratio["dp"] is not None and ratio["dp"] >= 1.01,
        "optimum_never_cut_off": None if stored else runs["dp_thermal"]["cutoff_s"] == 0,  # a reference omits it
        "ecms_thermal_no_dearer": (ratio["ecms_thermal"] is not None and ratio["ecms"] is not None
                                   and ratio["ecms_thermal"] <= ratio["ecms"]),
        "spinning_losses_harmless": runs["engine_only"]["cutoff_s"] == 0
                                    and runs["engine_only"]["max_motor_temp_c"] < release,
        "optimum_lowest": None if stored else min(r for k, r in ratio.items() if r is not None) >= OPTIMUM_SLACK,
    }
    by_cost = sorted((k for k in runs if k != "dp_thermal"), key=lambda k: runs[k]["fixed_price_cost_g"])
    by_other = sorted((k for k in runs if k != "dp_thermal"), key=lambda k: runs[k]["fixed_price_cost_g_other_price"])
    return {"name": name, "cycle": cycle, "scenario": scenario, "conditions": None if cond is None else cond.to_dict(),
            "value_of_knowing_heat": ratio["dp"], "checks": checks,
            "ranking_at_fixed_battery_price": by_cost, f"ranking_at_physics_v{3 - physics}_overheat_price": by_other,
            "thermal_task": all(v for v in checks.values() if v is not None), "runs": runs}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--physics", type=int, default=2, help="physics version (HevThermal-vN): 2 searches the "
                        "candidates, 1 drives physics v1's thermal tasks (the matrix before)")
    parser.add_argument("--quick", action="store_true", help="one candidate with a coarse optimum (a smoke test)")
    parser.add_argument("--screen", action="store_true", help="the screen: causal strategies only, over a grid of "
                        "routes, air, cooling and payload (minutes)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="these candidates only, merged into --out's "
                        "other candidates if it exists")
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.screen:
        return screen(args)
    candidates = QUICK if args.quick else (V1_TASKS if args.physics == 1 else CANDIDATES)
    kept: list[dict[str, Any]] = []
    if args.only:
        unknown = sorted(set(args.only) - {c[0] for c in candidates})
        if unknown:
            parser.error(f"--only: unknown candidate(s) {unknown}; candidates: {[c[0] for c in candidates]}")
        if args.out.is_file():
            kept = [r for r in json.loads(args.out.read_text())["candidates"] if r["name"] not in args.only]
        order = {c[0]: i for i, c in enumerate(candidates)}
        candidates = tuple(c for c in candidates if c[0] in args.only)
    else:
        order = {c[0]: i for i, c in enumerate(candidates)}
    t0 = time.perf_counter()
    results: list[dict[str, Any]] = list(kept)

    def record() -> dict[str, Any]:
        done = sorted(results, key=lambda r: order[r["name"]])
        return {"physics": args.physics, "quick": args.quick, "wall_s": time.perf_counter() - t0,
                "criteria": "dp frontier ratio >= 1.01; dp_thermal never cut off; ecms_thermal ratio <= ecms ratio; "
                            "engine_only (u = 0) never cut off and below the 60 °C release; no strategy's frontier "
                            "ratio below 0.999",
                "searched": len(done), "of": len(order),
                "tasks": [r["name"] for r in done if r["thermal_task"]], "candidates": done}

    args.out.parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as ex:
        threads = 1 if args.jobs > 1 else None
        futures = [ex.submit(run_candidate, c, args.physics, args.quick, threads) for c in candidates]
        for fut in tqdm(as_completed(futures), total=len(futures), desc="candidates"):
            results.append(fut.result())
            args.out.write_text(json.dumps(record(), indent=1) + "\n")  # what is done so far, candidate by candidate
    final = record()
    results = final["candidates"]
    for r in results:
        flags = " ".join(f"{k}={'-' if v is None else 'y' if v else 'n'}" for k, v in r["checks"].items())
        vk = r["value_of_knowing_heat"]
        print(f"{r['name']:24s} dp/dp_thermal {vk if vk is None else round(vk, 4)}  {flags}")
    print(f"thermal tasks: {final['tasks']}  ({final['wall_s']:.0f} s)")
    return 0


def screen(args: argparse.Namespace) -> int:
    """Write the screen's JSON: every cell, then where the blind ECMS is cut off while the spinning motor is not."""
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as ex:
        cells = SCREEN + SCREEN_WARM
        rows = list(tqdm(ex.map(screen_candidate, cells, [args.physics] * len(cells)), total=len(cells),
                         desc="screen"))
    binds = [r["name"] for r in rows if r["ecms_cut_off"] and not r["spinning_cut_off"]]
    record = {"physics": args.physics, "strategies": list(SCREEN_STRATEGIES), "wall_s": time.perf_counter() - t0,
              "cells": len(rows), "ecms_cut_off_spinning_not": binds,
              "ecms_thermal_cheaper_than_ecms": [r["name"] for r in rows if r["ecms_thermal_over_ecms"] <= 1.0],
              "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    print(f"{len(rows)} cells; the blind ECMS cut off, the spinning motor not: {binds}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
