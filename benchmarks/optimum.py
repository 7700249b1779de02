#!/usr/bin/env python
"""The thermal optimum as a yardstick: is it below every strategy, exact, converged and fast enough?

Writes ``benchmarks/results/optimum.json``:

* ``cells``: every built-in cycle × scenario (``paper``, ``hot``, ``summer``, ``hilly``,
  ``full_bus``) and generated bus cycles (``validation_bus:0..19``, 1,200-4,500 s, the learned
  policies' validation set; paper) and ``--fresh`` generated
  routes no set uses (:func:`fresh_cycles`: the six families in turn, the five scenarios in turn): each strategy's
  yardstick cost, final SOC and frontier ratio (cost / the optimum's frontier at the strategy's final SOC); the
  optimum's planned, replayed and realised cost, solve time and states. A run ending below the
  lowest SOC searched gets ``frontier_ratio_at_least`` (cost / F at that SOC: F is monotone, so
  this bounds its ratio from below); ``outside_and_undecided`` lists those whose bound is < 1. ``engine_only`` is the
  hybrid with u = 0 (its motor unused) and is checked like every strategy; ``conventional`` drives another vehicle (no
  motor) and is left out.
* ``convergence``: every bin halved and the splits doubled (``grid_scale=2``) on Beijing and HWFET
  in ``hot`` and US06 in ``paper``, and on ≤ 120 s cycles a very fine search (``grid_scale=4``):
  change of the cost at the default's final SOC.
* ``outside_checks``: the runs that ended below the frontier's lowest SOC with a lower bound < 1,
  against the optimum re-solved with a ±0.12 frontier.
* ``speed``: ``dp_thermal`` on HWFET, on the 1,300 s Beijing cycle and on ``validation_bus:4`` (4,440 s), ``dp`` on
  HWFET: each solve in a fresh process with the default threads and no plan on disk, its peak memory; with
  ``--before DIR`` the same solves of the planner in the source tree DIR (an earlier revision), one after the other.

    python benchmarks/optimum.py [--quick] [--jobs 2] [--generated 20] [--fresh 10] [--parts cells convergence speed]
    python benchmarks/optimum.py --parts cells --cells udds:hot beijing:paper --jobs 1 --out /tmp/o.json
    python benchmarks/optimum.py --parts convergence --convergence-cells us06:paper:2 udds_120s:hot:4
    python benchmarks/optimum.py --parts speed --before /path/to/earlier/checkout
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import warnings
from multiprocessing import Pool
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from hev_thermal_env import cycle_from_arrays, load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import ImplausibleCycleWarning
from hev_thermal_env.cycles.families import VALIDATION_SEED_BASE
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.score import Frontier
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.tasks import TEST_FAMILIES

OUT = Path(__file__).parent / "results" / "optimum.json"
CYCLES = ("hwfet", "udds", "us06", "wltc_3b", "beijing")
SCENARIOS = ("paper", "hot", "summer", "hilly", "full_bus")
STRATEGIES = ("engine_only", "rule", "ecms", "aecms", "ecms_thermal", "dp", "ppo")
TOLERANCE = 1e-3
#: Threads per optimum inside the worker pool (the pool itself fills the cores); the speed figures use the default.
THREADS = 1
PARTS = ("cells", "convergence", "speed", "outside")
#: Frontier half-width of the re-solve for runs that ended below the default frontier's lowest SOC: at least WIDE,
#: wider where a run ended further below the optimum's final SOC (by WIDE_MARGIN more than that run did).
WIDE, WIDE_MARGIN = 0.12, 0.02
#: Seeds of the fresh routes: 2**21 above the first validation seed (the validation set has 30 seeds from there, the
#: generalisation task's test routes 18 from 2**20 above it; training draws below it).
FRESH_SEED_BASE = VALIDATION_SEED_BASE + 2**21
#: The speed figures: (strategy, cycle), and issue targets for them (s).
SPEED_SOLVES = (("dp_thermal", "hwfet"), ("dp_thermal", "beijing"), ("dp", "hwfet"), ("dp_thermal", "validation_bus:4"))
SPEED_TARGETS_S = {"dp_thermal/hwfet": 10.0, "dp_thermal/beijing": 6.0, "dp_thermal/validation_bus:4": 60.0,
                   "dp/hwfet": 0.3}
#: One solve in a fresh process: plan time, peak memory, cost (printed as one JSON line).
_ONE_SOLVE = """
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
import importlib.util, pathlib
import hev_thermal_env
root = pathlib.Path.cwd()
if not (root / "hev_thermal_env" / "agents").exists():  # a plain checkout: its agents/ as hev_thermal_env.agents
    spec = importlib.util.spec_from_file_location("hev_thermal_env.agents", root / "agents" / "__init__.py",
                                                  submodule_search_locations=[str(root / "agents")])
    sys.modules["hev_thermal_env.agents"] = hev_thermal_env.agents = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hev_thermal_env.agents)
from hev_thermal_env import cycle_from_arrays, load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.evaluation.runner import run_strategy
name, cycle = sys.argv[1:3]
opts = {"plan_cache": False} if name == "dp_thermal" else {}
if cycle == "warmup":  # compiles every kernel the solve needs (kept on disk), so no solve timed later pays for it
    cycle = cycle_from_arrays(load_cycle("beijing").speed_mps[:31], name="warmup")
s = run_strategy(get_strategy(name, **opts), load_cycle(cycle), "paper").summary
d = s["strategy_settings"]
print(json.dumps({"solve_s": d.get("solve_s"), "plan_s": s["plan_s"], "cost_g": s["cost_g"],
                  "soc_final": s["soc_final"],
                  "planned_cost_g": d.get("planned_cost_g"), "max_states": d.get("max_states"),
                  "vehicle_steps": d.get("vehicle_steps_evaluated"),
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "package": hev_thermal_env.__file__,
                  "strategies": sys.modules[type(get_strategy(name)).__module__].__file__}))
"""


def frontier_sample(soc_final, cost_g, max_points: int = 200) -> dict[str, Any]:
    """Every k-th breakpoint of a frontier (and the last), at most about ``max_points``, for records and plots."""
    soc, cost = np.asarray(soc_final, dtype=float), np.asarray(cost_g, dtype=float)
    every = max(1, int(np.ceil(soc.size / max_points)))
    idx = np.unique(np.r_[np.arange(0, soc.size, every), soc.size - 1]) if soc.size else np.arange(0)
    return {"soc_final": [round(float(x), 6) for x in soc[idx]], "cost_g": [round(float(x), 4) for x in cost[idx]],
            "every_kth_breakpoint": every, "breakpoints": int(soc.size)}


def fresh_cycles(n: int) -> list[tuple[str, str]]:
    """``n`` generated routes no set uses (seeds from :data:`FRESH_SEED_BASE`), the generalisation task's six
    families in turn, each in the next of :data:`SCENARIOS`."""
    return [(f"{TEST_FAMILIES[k % len(TEST_FAMILIES)]}:{FRESH_SEED_BASE + k}", SCENARIOS[k % len(SCENARIOS)])
            for k in range(n)]


def _cycle(name: str):
    if name.endswith("_120s"):
        base = load_cycle(name[:-5])
        return cycle_from_arrays(base.speed_mps[:121], name=name)
    return load_cycle(name)


def _rows(cyc, scenario: str, names, frontier: Frontier) -> dict[str, dict]:
    """Each strategy on the cell: cost, final SOC, cutoff and derated seconds, and its frontier ratio."""
    rows = {}
    for name in names:
        s = run_strategy(get_strategy(name), cyc, scenario).summary
        ref = frontier.cost_at(s["soc_final"])
        rows[name] = {"cost_g": s["cost_g"], "soc_final": s["soc_final"], "cutoff_s": s["cutoff_s"],
                      "derated_s": s["derated_s"], "frontier_ratio": None if ref is None else s["cost_g"] / ref}
        if ref is None and s["soc_final"] < frontier.soc_final[0]:
            # below the lowest SOC searched F is at most F(soc_min) (monotone), so cost / F(soc_min) bounds the
            # ratio from below: a bound >= 1 shows the run is not below the frontier either
            rows[name]["frontier_ratio_at_least"] = s["cost_g"] / float(frontier.cost_g[0])
    return rows


def cell(task: tuple[str, str]) -> dict:
    cycle, scenario = task
    warnings.simplefilter("ignore")
    cyc = _cycle(cycle)
    t0 = time.perf_counter()
    opt = run_strategy(get_strategy("dp_thermal", threads=THREADS), cyc, scenario).summary
    wall = time.perf_counter() - t0
    d = opt["strategy_settings"]
    frontier = Frontier.from_settings(d)
    rows = _rows(cyc, scenario, STRATEGIES, frontier)
    beaten = [n for n, r in rows.items() if r["frontier_ratio"] is not None and r["frontier_ratio"] < 1 - TOLERANCE]
    outside_runs = [n for n, r in rows.items() if r["frontier_ratio"] is None]
    undecided = [n for n in outside_runs if rows[n].get("frontier_ratio_at_least", 0.0) < 1 - TOLERANCE]
    return {
        "cycle": cycle, "scenario": scenario, "optimum": {
            "cost_g": opt["cost_g"], "planned_cost_g": d["planned_cost_g"], "replayed_cost_g": d["replayed_cost_g"],
            "planned_vs_realised": opt["cost_g"] / d["planned_cost_g"] - 1.0, "soc_final": opt["soc_final"],
            "cutoff_s": opt["cutoff_s"], "derated_s": opt["derated_s"], "solve_s": d["solve_s"], "wall_s": wall,
            "max_states": d["max_states"], "frontier_points": len(d["frontier"]["soc_final"]),
            "frontier": {"soc_min": frontier.soc_min, **frontier_sample(frontier.soc_final, frontier.cost_g)}},
        "strategies": rows, "min_ratio": min((r["frontier_ratio"] for r in rows.values()
                                             if r["frontier_ratio"] is not None), default=None),
        "beaten_by": beaten, "outside_frontier": outside_runs, "outside_and_undecided": undecided,
    }


def convergence(task: tuple[str, str, float]) -> dict:
    cycle, scenario, scale = task
    warnings.simplefilter("ignore")
    cyc = _cycle(cycle)
    base = run_strategy(get_strategy("dp_thermal", threads=THREADS), cyc, scenario).summary
    t0 = time.perf_counter()
    fine = run_strategy(get_strategy("dp_thermal", grid_scale=scale, threads=THREADS), cyc, scenario).summary
    ref = Frontier.from_settings(fine["strategy_settings"]).cost_at(base["soc_final"])
    return {"cycle": cycle, "scenario": scenario, "grid_scale": scale, "default_cost_g": base["cost_g"],
            "fine_cost_at_same_soc_g": ref, "change": None if ref is None else base["cost_g"] / ref - 1.0,
            "fine_solve_s": fine["strategy_settings"]["solve_s"], "fine_wall_s": time.perf_counter() - t0,
            "fine_max_states": fine["strategy_settings"]["max_states"]}


def outside(task: tuple[str, str, tuple[str, ...], float]) -> dict:
    """The optimum re-solved with a wider frontier (± the task's half-width, :func:`_outside_tasks`) for runs that
    ended below the default one's lowest SOC: their frontier ratio there."""
    cycle, scenario, names, halfwidth = task
    warnings.simplefilter("ignore")
    cyc = _cycle(cycle)
    opt = run_strategy(get_strategy("dp_thermal", threads=THREADS, frontier_halfwidth=halfwidth), cyc,
                       scenario).summary
    frontier = Frontier.from_settings(opt["strategy_settings"])
    rows = _rows(cyc, scenario, names, frontier)
    return {"cycle": cycle, "scenario": scenario, "frontier_halfwidth": halfwidth, "soc_min": frontier.soc_min,
            "optimum_cost_g": opt["cost_g"], "solve_s": opt["strategy_settings"]["solve_s"], "strategies": rows}


def one_solve(name: str, cycle: str, tree: str | None = None) -> dict:
    """:data:`_ONE_SOLVE` in a fresh process run from the source ``tree`` (default: this checkout), which comes first
    on the path; default threads, no plan on disk, paper conditions. Raises when the solve fails (with its stderr) or
    when the package or the strategies were imported from elsewhere."""
    root = Path(tree).resolve() if tree is not None else Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-c", _ONE_SOLVE, name, cycle], env=env, capture_output=True, text=True,
                         cwd=root)
    if run.returncode != 0:
        raise RuntimeError(f"{name} on {cycle} in {root} failed:\n{run.stderr[-3000:]}")
    row = {**json.loads(run.stdout.strip().splitlines()[-1]), "process_wall_s": time.perf_counter() - t0}
    for what in ("package", "strategies"):
        if not Path(row[what]).resolve().is_relative_to(root):
            raise RuntimeError(f"{name} on {cycle}: the {what} came from {row[what]}, not from {root} (an installed "
                               f"copy shadows the tree: run from an environment without it)")
    return row


def speed(before: str | None = None, solves=SPEED_SOLVES, repeats: int = 3) -> dict:
    """Solve times with the default threads (every core), no plan cache, one fresh process each; each solve
    ``repeats`` times, alternating with the same solve of the planner in the source tree ``before`` if given (not the
    4,440 s cycle: the earlier solver takes too long there). A row is the run with the median solve time; all the
    times are in ``solve_s_runs`` (a shared virtual machine's speed drifts by tens of per cent within minutes)."""
    out: dict = {"after": {}, "before": {}, "before_tree": before, "targets_s": SPEED_TARGETS_S, "repeats": repeats}
    for tree in (None, before) if before is not None else (None,):
        for name in ("dp_thermal", "dp"):
            one_solve(name, "warmup", tree)

    def median_run(runs: list[dict]) -> dict:
        row = sorted(runs, key=lambda r: r["solve_s"])[len(runs) // 2]
        return {**row, "solve_s_runs": [r["solve_s"] for r in runs]}

    for name, cycle in solves:
        key = f"{name}/{cycle}"
        trees = [None] + ([before] if before is not None and cycle != "validation_bus:4" else [])
        runs: dict = {tree: [] for tree in trees}
        for _ in range(repeats):
            for tree in trees:
                runs[tree].append(one_solve(name, cycle, tree))
        new = out["after"][key] = median_run(runs[None])
        new["met"] = new["solve_s"] <= SPEED_TARGETS_S[key]
        print(f"speed {key}: {new['solve_s']:.2f} s (median of {repeats})", flush=True)
        if len(trees) > 1:
            old = out["before"][key] = median_run(runs[before])
            new["speedup"] = old["solve_s"] / new["solve_s"]
            print(f"speed {key} before: {old['solve_s']:.2f} s", flush=True)
    return out


def _args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: the first 120 s of udds and beijing, "
                    "1 generated cycle's first 120 s, one convergence cell, no speed figures (about 1 min)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--generated", type=int, default=20,
                    help="generated bus cycles (validation_bus:0..N-1: long, congested, launch, hilly, mixed), paper")
    ap.add_argument("--fresh", type=int, default=10,
                    help="generated routes no set uses (fresh_cycles: six families, five scenarios in turn)")
    ap.add_argument("--speed-repeats", type=int, default=3, help="speed: runs of each solve (the median is reported)")
    ap.add_argument("--before", default=None, metavar="DIR",
                    help="speed: also time the planner of this source tree (an earlier checkout)")
    ap.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                    help="what to run; the parts left out are kept from the existing JSON (default: all)")
    ap.add_argument("--cells", nargs="+", default=None, metavar="CYCLE:SCENARIO",
                    help="only these cells, in this order (e.g. udds:hot beijing:paper); default: every cell")
    ap.add_argument("--convergence-cells", nargs="+", default=None, metavar="CYCLE:SCENARIO:SCALE",
                    help="only these convergence cells (e.g. us06:paper:2 udds_120s:hot:4); default: all of them")
    ap.add_argument("--out", default=None, help=f"JSON path (default {OUT.relative_to(OUT.parents[2])}; with --quick "
                    "optimum_quick.json next to it)")
    return ap.parse_args()


def _tasks(args: argparse.Namespace) -> tuple[list[tuple[str, str]], list[tuple[str, str, float]]]:
    """The cells and the convergence cells to run (longest cycles first: the pool ends together)."""
    if args.quick:
        tasks = [(c, s) for c in ("udds_120s", "beijing_120s") for s in ("paper", "hot")] + [("random_bus:1000_120s",
                                                                                              "paper")]
        conv = [("beijing_120s", "hot", 2.0)]
    else:
        tasks = [(c, s) for c in CYCLES for s in SCENARIOS] + [(f"validation_bus:{i}", "paper")
                                                                for i in range(args.generated)]
        tasks += fresh_cycles(args.fresh)
        conv = [(c, s, 4.0) for c in ("udds_120s", "beijing_120s", "us06_120s") for s in ("paper", "hot")]
        conv += [("beijing", "hot", 2.0), ("hwfet", "hot", 2.0), ("us06", "paper", 2.0)]
    if args.cells:
        tasks = [tuple(c.rsplit(":", 1)) for c in args.cells]
    else:
        tasks.sort(key=lambda t: -len(_cycle(t[0]).speed_mps))
    if args.convergence_cells:
        conv = [(c, s, float(k)) for c, s, k in (t.rsplit(":", 2) for t in args.convergence_cells)]
    tasks = tasks if "cells" in args.parts else []
    return tasks, conv if "convergence" in args.parts else []


def _result(cells: list[dict], convs: list[dict], wides: list[dict], speed_figures: dict | None, partial: bool,
            wall_s: float) -> dict:
    """The JSON: every part and its summary."""
    ratios = [c["min_ratio"] for c in cells if c["min_ratio"] is not None]
    changes = [abs(c["change"]) for c in convs if c["change"] is not None]
    checked = {(w["cycle"], w["scenario"], n): r["frontier_ratio"] for w in wides for n, r in w["strategies"].items()}
    undecided = [(c["cycle"], c["scenario"], n) for c in cells for n in c["outside_and_undecided"]]
    still = [u for u in undecided if checked.get(u) is None or checked[u] < 1 - TOLERANCE]
    return {
        "cells": sorted(cells, key=lambda c: (c["cycle"], c["scenario"])), "convergence": convs,
        "speed": speed_figures, "tolerance": TOLERANCE, "partial": partial, "outside_checks": wides,
        "summary": {
            "cells": len(cells), "cells_beaten": sum(bool(c["beaten_by"]) for c in cells),
            "runs_outside_undecided": len(undecided),
            "runs_outside_after_wide_check": ["/".join(u) for u in still],
            "min_ratio_wide_check": min((r for r in checked.values() if r is not None), default=None),
            "min_ratio": min(ratios, default=None),
            "max_planned_vs_realised": max((abs(c["optimum"]["planned_vs_realised"]) for c in cells), default=None),
            "max_grid_change": max(changes, default=None), "wall_s": wall_s},
    }


def _outside_tasks(cells: list[dict]) -> list[tuple[str, str, tuple[str, ...], float]]:
    """The cells whose runs ended below the frontier's lowest SOC with a lower bound < 1, those runs, and the frontier
    half-width that reaches them (at least :data:`WIDE`)."""
    todo: dict[tuple[str, str], list[str]] = {}
    width: dict[tuple[str, str], float] = {}
    for c in cells:
        for n in c["outside_and_undecided"]:
            k = (c["cycle"], c["scenario"])
            todo.setdefault(k, []).append(n)
            below = c["optimum"]["soc_final"] - c["strategies"][n]["soc_final"] + WIDE_MARGIN
            width[k] = max(width.get(k, WIDE), math.ceil(below * 100.0) / 100.0)
    return [(k[0], k[1], tuple(v), width[k]) for k, v in todo.items()]


def main() -> None:
    args = _args()
    warnings.simplefilter("ignore", ImplausibleCycleWarning)
    tasks, conv = _tasks(args)
    t0 = time.perf_counter()
    out = Path(args.out) if args.out else OUT.with_name("optimum_quick.json" if args.quick else OUT.name)
    out.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(out.read_text()) if out.is_file() else {}
    cells: list[dict] = [] if "cells" in args.parts else old.get("cells", [])
    convs: list[dict] = [] if "convergence" in args.parts else old.get("convergence", [])
    wides: list[dict] = [] if "outside" in args.parts else old.get("outside_checks", [])

    def write(partial: bool, speed_figures: dict | None = None) -> dict:
        result = _result(cells, convs, wides, speed_figures, partial, time.perf_counter() - t0)
        result.update({k: v for k, v in old.items() if k not in result})  # what other checks added to the file
        atomic_write_json(out, result)
        return result

    with Pool(args.jobs) as pool:  # results are written as they come: an interrupted run keeps what it finished
        for c in tqdm(pool.imap_unordered(cell, tasks), total=len(tasks), desc="cells", unit="cell"):
            cells.append(c)
            write(partial=True)
        for c in tqdm(pool.imap_unordered(convergence, conv), total=len(conv), desc="convergence", unit="cell"):
            convs.append(c)
            write(partial=True)
    if "outside" in args.parts:
        todo = _outside_tasks(cells)
        with Pool(args.jobs) as pool:
            for w in tqdm(pool.imap_unordered(outside, todo), total=len(todo), desc="outside runs", unit="cell"):
                wides.append(w)
                write(partial=True, speed_figures=old.get("speed"))
    speed_figures = old.get("speed") if "speed" not in args.parts else None if args.quick else speed(
        args.before, repeats=args.speed_repeats)
    result = write(partial=False, speed_figures=speed_figures)
    print(json.dumps(result["summary"], indent=1))
    for c in result["cells"]:
        print(f"{c['cycle']:>16} {c['scenario']:>8}  min ratio {c['min_ratio']}  beaten by {c['beaten_by']}  "
              f"outside {c['outside_frontier']}  solve {c['optimum']['solve_s']:.1f} s")


if __name__ == "__main__":
    main()
