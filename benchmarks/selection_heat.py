#!/usr/bin/env python
"""The heat rule of PPO's selection: candidates (policies of ``train.py`` and ``ecms_thermal`` variants) on the
selection routes against the thermal optimum, and in the heat against ``ecms_thermal``. It chose the default PPO
family's band center, SOC offset and teacher's price floor (docs/training.md, "The band's center and a cool motor's
price"; ``benchmarks/results/selection_heat.json``) and its weight on the demonstrations where the motor derates
(docs/training.md, "Fitting the teacher where the motor derates"; ``benchmarks/results/selection_derating.json``, with
``--hilly-routes`` the ten routes) and the teacher's price of regeneration (docs/training.md, "Regeneration priced
where it derates"; ``benchmarks/results/selection_braking.json``, with ``--express-routes`` and ``--proxies``). With
fresh routes in ``paper`` and ``hot`` (``--hot-routes``, no summer or hilly task) it judged two whole families by the
issue's own criteria (docs/training.md, "Two families judged on fresh routes";
``benchmarks/results/selection_families.json``; the same routes in ``summer`` against the optimum:
``selection_families_summer.json``).

On ``validation_bus:20..29`` in ``paper`` and ``validation_bus:20..24`` in ``summer`` and ``hilly`` (the training's
selection routes; never a test route nor one that ``ppo_vs_dp.py`` judges on), and with ``--express-routes`` further
routes in ``paper`` (seeds between the validation set's and the test routes') and with ``--hot-routes`` routes in
``hot``, per candidate: the frontier ratio
(mean, worst), the runs whose safety cost exceeds the optimum's + 5 % where it derates, the runs beyond |ΔSOC| 0.02
and the safety cost beside the optimum's. On ``validation_bus:20..29`` in ``summer`` and ``hilly`` (``--proxies``,
e.g. also ``hot``): the corrected fuel and the reward's cost relative to ``ecms_thermal``'s (the leaderboard's, fixed
price; in ``hot`` the cost, which prices the motor's heat, is the one the task scores), the runs whose cost is more
than 1 % above ``ecms_thermal``'s and the safety cost. The
optimum's references are solved once into ``--references`` (a local cache, like a run directory) and reused while
current::

    PYTHONPATH=. python benchmarks/selection_heat.py --jobs 2 --out benchmarks/results/selection_heat.json \\
        --policy "default=runs/learned/ppo_center_floor/seed_0" \\
        --teacher 'floor 0.5={"x_price": "margin", "k_soc": 1.5, "margin_floor": 0.5}'

Solving the references takes about 12 minutes with 2 jobs (the hilly motorway routes 25..29 with ``--hilly-routes``
another 4 to 19 minutes each); a candidate about a minute. A policy is driven with the
band center it was trained with (``PPOStrategy.env_options``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ROUTES = tuple(f"validation_bus:{i}" for i in range(20, 30))
HEAT_ROUTES = ROUTES[:5]
PROXY_SCENARIOS = ("summer", "hilly")


def selection_tasks(routes: tuple[str, ...] = ROUTES, heat_routes: tuple[str, ...] = HEAT_ROUTES,
                    hilly_routes: tuple[str, ...] | None = None, express_routes: tuple[str, ...] = (),
                    hot_routes: tuple[str, ...] = ()) -> list[Any]:
    """The selection routes as tasks scored against the optimum (not registered: nothing else scores on them);
    ``hilly_routes``: the hilly task's, if not ``heat_routes``; ``express_routes``: further routes in ``paper``;
    ``hot_routes``: routes in ``hot``. A scenario without routes has no task."""
    from hev_thermal_env.tasks import Task

    hilly = heat_routes if hilly_routes is None else hilly_routes
    wanted = [("selection-paper", "the selection routes, the paper's conditions", routes, "paper"),
              ("selection-summer", "the selection routes, summer", heat_routes, "summer"),
              ("selection-hilly", "the selection routes, hills", hilly, "hilly"),
              ("selection-express", "further selection routes, the paper's conditions", express_routes, "paper"),
              ("selection-hot", "the selection routes, a hot day", hot_routes, "hot")]
    return [Task(name, 1, text, tuple(cycles), scenario) for name, text, cycles, scenario in wanted if cycles]


def proxy_tasks(routes: tuple[str, ...] = ROUTES, scenarios: tuple[str, ...] = PROXY_SCENARIOS) -> list[Any]:
    """The selection routes in ``scenarios`` (the heat and the hills by default), scored against ``ecms_thermal`` (no
    reference needed)."""
    from hev_thermal_env.tasks import Task

    return [Task(f"selection-{s}-all", 1, f"the selection routes, {s}", routes, s) for s in scenarios]


def ensure_reference(task: Any, directory: Path, jobs: int) -> dict[str, Any]:
    """The task's reference from ``directory``, solved and saved there first unless current."""
    from hev_thermal_env.evaluation.references import compute_reference, load_reference, save_reference

    try:
        return load_reference(task, directory)
    except (FileNotFoundError, ValueError):
        print(f"solving the optimum on {task.id} ({len(task.cycles)} routes, {jobs} at a time)", flush=True)
        save_reference(compute_reference(task, progress=lambda line: print(line, flush=True), jobs=jobs), directory)
        return load_reference(task, directory)


def strategy_of(candidate: tuple[str, str, Any]) -> Any:
    from hev_thermal_env.agents import get_strategy

    kind, _, what = candidate
    return get_strategy(f"ppo:{what}") if kind == "policy" else get_strategy("ecms_thermal", **what)


def against_optimum(result: dict[str, Any], reference: dict[str, Any]) -> dict[str, Any]:
    """A candidate's result record on a task, scored as the leaderboard scores (``score_result``); the frontier ratio
    of every route too, in the task's order (None off the frontier)."""
    from hev_thermal_env.evaluation.leaderboard import score_result

    scored = score_result(result, reference)
    every = [row["frontier_ratio"] for row in scored["rows"]]
    ratios = [r for r in every if r is not None]
    return {"frontier_ratio_mean": float(np.mean(ratios)) if ratios else None,
            "frontier_ratio_worst": float(np.max(ratios)) if ratios else None, "frontier_ratios": every,
            "above_optimum_safety": scored["above_optimum_safety"], "beyond_soc_bound": scored["beyond_soc_bound"],
            "safety_cost_s": float(sum(e["safety_cost_s"] for e in result["episodes"])),
            "optimum_safety_cost_s": float(sum(e["optimum"]["safety_cost_s"] for e in reference["episodes"]))}


def against_ecms_thermal(result: dict[str, Any], baseline: dict[str, Any]) -> dict[str, Any]:
    """A candidate's result record over ``ecms_thermal``'s on the same episodes: corrected fuel and the reward's cost
    (what the tasks score: with the overheat and cutoff prices, which corrected fuel leaves out) per episode (mean,
    worst), and both safety costs."""
    pairs = list(zip(result["episodes"], baseline["episodes"], strict=True))
    ratios = [row["fuel_corrected_l_per_100km"] / base["fuel_corrected_l_per_100km"] for row, base in pairs]
    costs = [row["cost_g"] / base["cost_g"] for row, base in pairs]
    return {"fuel_vs_ecms_thermal_mean": float(np.mean(ratios)), "fuel_vs_ecms_thermal_worst": float(np.max(ratios)),
            "cost_vs_ecms_thermal_mean": float(np.mean(costs)), "cost_vs_ecms_thermal_worst": float(np.max(costs)),
            "cost_above_ecms_thermal_1pct": sum(c > 1.01 for c in costs),
            "safety_cost_s": float(sum(e["safety_cost_s"] for e in result["episodes"])),
            "ecms_thermal_safety_cost_s": float(sum(e["safety_cost_s"] for e in baseline["episodes"]))}


def driver(strategy: Any, name: str) -> Any:
    """``drive(task)``: the candidate's result record on ``task``, each set of episodes (scenario, routes, seeds,
    start) driven once: a task scored against the optimum and a proxy on the same routes share their runs."""
    from hev_thermal_env.evaluation.submission import result_of_strategy

    runs: dict[tuple, dict[str, Any]] = {}

    def drive(task: Any) -> dict[str, Any]:
        key = (task.scenario, task.cycles, task.seeds, task.start_s)
        if key not in runs:
            runs[key] = result_of_strategy(task, strategy, name)
        return runs[key]

    return drive


def parse_candidates(policies: list[str], teachers: list[str]) -> list[tuple[str, str, Any]]:
    out = []
    for item in policies:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise SystemExit(f"--policy {item!r}: expected NAME=RUN_DIR_OR_ZIP")
        out.append(("policy", name, path))
    for item in teachers:
        name, sep, text = item.partition("=")
        try:
            options = json.loads(text) if sep and name else None
        except ValueError as exc:
            raise SystemExit(f"--teacher {item!r}: the options are not JSON ({exc})") from None
        if not isinstance(options, dict):
            raise SystemExit(f"--teacher {item!r}: expected NAME=JSON object of ecms_thermal's options")
        out.append(("teacher", name, options))
    if not out:
        raise SystemExit("give at least one --policy or --teacher")
    return out


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--policy", action="append", default=[], metavar="NAME=PATH", help="a policy of train.py")
    p.add_argument("--teacher", action="append", default=[], metavar="NAME=JSON", help="ecms_thermal's options")
    p.add_argument("--routes", nargs="+", default=list(ROUTES), metavar="CYCLE", help="the paper and proxy routes")
    p.add_argument("--heat-routes", nargs="*", default=list(HEAT_ROUTES), metavar="CYCLE",
                   help="the summer (and, without --hilly-routes, hilly) routes scored against the optimum (none: "
                        "no summer task)")
    p.add_argument("--hilly-routes", nargs="*", default=None, metavar="CYCLE",
                   help="the hilly routes scored against the optimum (default: --heat-routes; none: no hilly task); "
                        "keep their references in a --references directory of their own: the task keeps its name, "
                        "so the cached hilly reference of other routes is solved again")
    p.add_argument("--express-routes", nargs="+", default=[], metavar="CYCLE",
                   help="further routes in paper scored against the optimum (e.g. bus_express:2147483756; seeds "
                        "between the validation set's and the test routes', which no training run draws)")
    p.add_argument("--hot-routes", nargs="+", default=[], metavar="CYCLE",
                   help="routes in hot scored against the optimum")
    p.add_argument("--proxies", nargs="+", default=list(PROXY_SCENARIOS), metavar="SCENARIO",
                   help="the scenarios in which the routes are scored against ecms_thermal")
    p.add_argument("--references", default=str(ROOT / "runs" / "selection_references"), metavar="DIR")
    p.add_argument("--jobs", type=int, default=1, metavar="N", help="routes solved at once")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "selection_heat.json"), metavar="FILE")
    return p


def tasks_of(args: argparse.Namespace) -> list[Any]:
    """The tasks scored against the optimum that the command line asks for."""
    hilly = None if args.hilly_routes is None else tuple(args.hilly_routes)
    return selection_tasks(tuple(args.routes), tuple(args.heat_routes), hilly, tuple(args.express_routes),
                           tuple(args.hot_routes))


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.jobs < 1:
        raise SystemExit(f"--jobs must be at least 1, got {args.jobs}")
    candidates = parse_candidates(args.policy, args.teacher)
    from hev_thermal_env.evaluation.submission import result_of_strategy
    from hev_thermal_env.io import atomic_write_json
    from hev_thermal_env.physics.fingerprint import physics_fingerprint

    t0 = time.perf_counter()
    tasks = tasks_of(args)
    references = {t.id: ensure_reference(t, Path(args.references), args.jobs) for t in tasks}
    record: dict[str, Any] = {
        "physics_fingerprint": physics_fingerprint(), "routes": args.routes, "heat_routes": args.heat_routes,
        "hilly_routes": list(args.heat_routes if args.hilly_routes is None else args.hilly_routes),
        "express_routes": args.express_routes,
        "hot_routes": args.hot_routes,
        "proxies": args.proxies,
        "references": {k: {"wall_s": r["wall_s"], "jobs": r["jobs"]} for k, r in references.items()},
        "candidates": {}}
    proxies = proxy_tasks(tuple(args.routes), tuple(args.proxies))
    baselines = {t.scenario: result_of_strategy(t, "ecms_thermal") for t in proxies}
    for cand in candidates:
        t1 = time.perf_counter()
        drive = driver(strategy_of(cand), cand[1])
        row = {"kind": cand[0], "what": cand[2]}
        row.update({t.id: against_optimum(drive(t), references[t.id]) for t in tasks})
        row.update({f"{t.scenario} vs ecms_thermal": against_ecms_thermal(drive(t), baselines[t.scenario])
                    for t in proxies})
        row["wall_s"] = round(time.perf_counter() - t1, 1)
        record["candidates"][cand[1]] = row
        above = sum(row[t.id]["above_optimum_safety"] for t in tasks)
        heat = ", ".join(f"{t.scenario} fuel / ecms_thermal "
                         f"{row[f'{t.scenario} vs ecms_thermal']['fuel_vs_ecms_thermal_mean']:.4f} (cost "
                         f"{row[f'{t.scenario} vs ecms_thermal']['cost_vs_ecms_thermal_mean']:.4f})" for t in proxies)
        print(f"{cand[1]}: runs above the optimum + 5 % {above}, paper ratio "
              f"{row[tasks[0].id]['frontier_ratio_mean']:.4f}, {heat}", flush=True)
    record["wall_s"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(args.out, record)
    print(f"wrote {args.out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
