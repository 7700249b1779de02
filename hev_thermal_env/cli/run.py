"""The subcommands ``run``, ``benchmark`` (the main job), ``paper`` and ``performance`` of ``evaluate.py``, each
described in :data:`COMMANDS`.

``paper``'s report is the maintainers' comparison of the model with the figures it was calibrated to; it lives in the
workshop of a source checkout, ``tools/paper`` (docs/development.md), and is imported only when the command runs.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import get_strategy, list_strategies
from hev_thermal_env.cycles import expand_cycle_names, list_cycles, load_cycle
from hev_thermal_env.evaluation import benchmark as bench
from hev_thermal_env.evaluation.executors import EXECUTORS
from hev_thermal_env.evaluation.plots import FUEL_CHART_FILE, plot_run
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.score import REFERENCE
from hev_thermal_env.io import atomic_write_json, atomic_write_text, check_output_path, check_writable_dir
from hev_thermal_env.physics import Conditions, VehicleConfig, paper_bus
from hev_thermal_env.physics.config import COOLANT_MODES
from hev_thermal_env.physics.performance import performance_report, table3_paper
from hev_thermal_env.scenarios import get_scenario, list_scenarios
from hev_thermal_env.tasks import get_task, list_tasks

DP_STRATEGIES = ("dp", "dp_thermal")
RUN_EXAMPLES = (
    "python evaluate.py run --cycle hwfet --strategy ecms",
    "python evaluate.py run --cycle beijing --strategy ppo:runs/ppo --json r.json --trace r.csv --plot r.png",
    "python evaluate.py run --cycle udds --strategy dp --dp-soc-points 801 --dp-actions 81",
    "python evaluate.py run --cycle my_route.csv --strategy rule --scenario hot",
    "python evaluate.py run --cycle hwfet --strategy aecms --option kp=10",
)
BENCHMARK_EXAMPLES = (
    "python evaluate.py benchmark --out results                       # the README's table",
    "python evaluate.py benchmark --cycles hwfet beijing --scenarios paper hot --out results_hot",
    "python evaluate.py benchmark --task udds-hot --strategies engine_only rule ecms_thermal --out results_udds_hot",
    "python evaluate.py benchmark --strategies rule dp ppo ppo:runs/ppo --cycles udds --jobs 2 --out cmp",
    "python evaluate.py benchmark --strategies rule --family ppo5=runs/s0,runs/s1,runs/s2,runs/s3,runs/s4 --out fam",
    "python evaluate.py benchmark --family ppo_hot=runs/hot_seeds --out fam   # every train.py run in the folder",
    "python evaluate.py benchmark --executor ray --out results_ray        # one Ray task per run",
    "python evaluate.py benchmark --executor ray --address HEAD:6379 --out results   # on a Ray cluster",
)


#: The paper's rows of Table 3 (a run of :data:`~hev_thermal_env.physics.performance.TABLE3_RUNS`) by starting
#: temperature: thermal model off, or on with the motor starting at 30 °C or 50 °C (the paper ran those with the
#: coolant closed). Other starting temperatures have no paper row: their comparison column is left empty.
PAPER_ROWS = {None: ("off", "thermal off"), 30.0: ("30c", "30 °C start, coolant closed"),
              50.0: ("50c", "50 °C start, coolant closed")}
FIGURES = (("top speed", "top_speed_kmh", "km/h"), ("0-60 km/h", "accel_0_60_s", "s"),
           ("speed on 4 % grade", "grade_4pct_speed_kmh", "km/h"))
PERFORMANCE_EXAMPLES = (
    "python evaluate.py performance --no-thermal --json results/performance.json   # paper: thermal off",
    "python evaluate.py performance --initial-motor-temp-c 30 --coolant off         # paper: 30 °C start",
    "python evaluate.py performance --initial-motor-temp-c 50 --coolant off         # paper: 50 °C start",
    "python evaluate.py performance --config my_bus.yaml",
)


def strategies_help() -> str:
    """The strategy names for the help texts, with the ``ppo:PATH`` form."""
    names = [n for n in list_strategies() if n != "ppo"]
    return f"{', '.join(names)}, ppo (the shipped policy) or ppo:PATH (a train.py run directory or model zip)"


def run_arguments(p) -> None:
    p.add_argument("--cycle", required=True, metavar="NAME",
                   help=f"built-in cycle ({', '.join(list_cycles())}), a generated one (FAMILY:SEED, e.g. "
                        f"bus_long:7, or validation_bus:K) or a CSV path (time_s,speed_mps[,grade])")
    p.add_argument("--strategy", required=True, metavar="NAME", help=strategies_help())
    p.add_argument("--scenario", default="paper", metavar="S", help=f"one of {', '.join(list_scenarios())}")
    p.add_argument("--seed", type=int, default=0, help="reset seed, 0 or more (draws the random scenario)")
    p.add_argument("--json", metavar="PATH", help="write the summary as JSON here")
    p.add_argument("--trace", metavar="PATH.csv", help="write the per-second info fields as CSV here")
    p.add_argument("--plot", metavar="PATH.png", help="draw speed, SOC, motor temperature, heat index and split")
    p.add_argument("--dp-soc-points", type=int, metavar="N",
                   help="dp: SOC grid points per stage (the strategy's default: 151)")
    p.add_argument("--dp-actions", type=int, metavar="M",
                   help="dp/dp_thermal: splits u in the backward pass / the search (defaults: 15 / 31)")
    p.add_argument("--dp-grid-scale", type=float, metavar="F",
                   help="dp_thermal: divide every bin of the search by F and multiply its splits (default: 1)")
    p.add_argument("--dp-on-infeasible", choices=["raise", "closest"], default=None,
                   help="dp/dp_thermal when the final-SOC band is unreachable: raise (the default) or plan for the "
                        "nearest reachable band")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="extra strategy option (value parsed as JSON when possible), repeatable; an unknown key "
                        "lists the strategy's options")


def strategy_options(args) -> dict[str, Any]:
    """The strategy's keyword options from the command line (checked)."""
    options: dict[str, Any] = {}
    for item in args.option:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--option {item!r}: expected KEY=VALUE")
        try:  # the value as JSON when it parses, else the text
            options[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            options[key.strip()] = value
    given = {k: v for k, v in (("n_soc", args.dp_soc_points), ("n_u", args.dp_actions),
                               ("on_infeasible", args.dp_on_infeasible), ("grid_scale", args.dp_grid_scale))
             if v is not None}
    base = args.strategy.partition(":")[0]
    if given and base not in DP_STRATEGIES:
        raise ValueError(f"--dp-soc-points/--dp-actions/--dp-grid-scale/--dp-on-infeasible apply to "
                         f"{', '.join(DP_STRATEGIES)} only, not to {args.strategy!r}")
    if "n_soc" in given and base != "dp":
        raise ValueError(f"--dp-soc-points applies to dp only; {base} bins the SOC (use --dp-grid-scale)")
    if "grid_scale" in given and base != "dp_thermal":
        raise ValueError(f"--dp-grid-scale applies to dp_thermal only; {base} takes --dp-soc-points")
    if "grid_scale" in given and not given["grid_scale"] > 0:
        raise ValueError(f"--dp-grid-scale must be > 0, got {given['grid_scale']}")
    for key, flag in (("n_soc", "--dp-soc-points"), ("n_u", "--dp-actions")):
        if key in given and given[key] < 2:
            raise ValueError(f"{flag} must be at least 2, got {given[key]}")
    return options | given


def format_summary(s: dict[str, Any]) -> str:
    """A readable block of a run's metrics (its summary)."""
    ratio = s["net_energy_ratio"]
    rows = [
        ("distance", f"{s['distance_km']:.3f}", "km"),
        ("fuel", f"{s['fuel_g']:.1f}", "g"),
        ("fuel", f"{s['fuel_l_per_100km']:.3f}", "L/100 km"),
        ("corrected fuel", f"{s['fuel_corrected_l_per_100km']:.3f}", "L/100 km"),
        ("  SOC correction", f"{s['soc_correction_l_per_100km']:+.3f}", "L/100 km"),
        ("  miss correction", f"{s['miss_correction_l_per_100km']:+.3f}", "L/100 km"),
        ("yardstick cost", f"{s['cost_g']:.1f}", "g (fuel + priced miss + overheat)"),
        ("SOC start -> end", f"{s['soc_initial']:.4f} -> {s['soc_final']:.4f}", f"(delta {s['delta_soc']:+.4f})"),
        ("J1711 charge-sustaining", "yes" if s["charge_sustaining"] else "no",
         f"(net battery / fuel energy {'n/a' if ratio is None else f'{100.0 * ratio:+.2f} %'})"),
        ("missed wheel energy", f"{s['missed_wheel_energy_kwh']:.3f}", "kWh"),
        ("max speed deficit", f"{s['trace_miss_max_mps']:.3f}", "m/s"),
        ("max motor temperature", f"{s['max_motor_temp_c']:.1f}", "degC"),
        ("max heat index", f"{s['heat_index_max']:.3f}", "-"),
        ("time derated (PWM > 0)", f"{s['derated_s']:.0f}", "s"),
        ("time cut off (70 degC)", f"{s['cutoff_s']:.0f}", "s"),
        ("wall time (planning)", f"{s['wall_s']:.2f} ({s['plan_s']:.2f})", "s"),
    ]
    head = f"{s['strategy']} on {s['cycle']} ({s['scenario']} scenario)"
    lines = [head, "-" * len(head)] + [f"  {name:<26}{value:>24}  {unit}" for name, value, unit in rows]
    settings = s.get("strategy_settings") or {}
    keys = ("grid", "n_u", "solve_s", "soc_band_used", "final_soc_feasible", "planned_cost_g", "max_states",
            "equivalence_factor", "s0", "kp", "ki")
    shown = {k: settings[k] for k in keys if k in settings}
    if shown:
        lines.append("  settings: " + ", ".join(f"{k}={_short(v)}" for k, v in shown.items()))
    return "\n".join(lines)


def _short(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(_short(x) for x in v) + "]"
    return str(v)


def run(args) -> int:
    # validate everything before the (possibly long) run
    if args.seed < 0:
        raise ValueError(f"--seed must be 0 or more, got {args.seed}")
    scenario = get_scenario(args.scenario)
    cycle = load_cycle(args.cycle)
    strategy = get_strategy(args.strategy, **strategy_options(args))
    for path in (args.json, args.trace, args.plot):
        if path:
            check_output_path(path)
    if args.plot and not str(args.plot).lower().endswith(".png"):
        raise ValueError(f"--plot {args.plot!r}: expected a .png path")
    result = run_strategy(strategy, cycle, scenario, seed=args.seed)
    s = result.summary
    print(format_summary(s))
    if args.json:
        atomic_write_json(args.json, result.to_json_dict())
        print(f"wrote {args.json}")
    if args.trace:
        atomic_write_text(args.trace, result.trace_csv())
        print(f"wrote {args.trace}")
    if args.plot:
        title = (f"{s['strategy']} on {s['cycle']} ({s['scenario']}): corrected fuel "
                 f"{s['fuel_corrected_l_per_100km']:.2f} L/100 km, SOC {s['soc_initial']:.3f} -> {s['soc_final']:.3f}")
        plot_run({s["strategy"]: result.trace}, args.plot, title=title)
        print(f"wrote {args.plot}")
    return 0


def benchmark_arguments(p) -> None:
    p.add_argument("--cycles", nargs="+", default=None, metavar="CYCLE",
                   help=f"built-in cycles ({', '.join(list_cycles())}), generated ones (FAMILY:SEED, "
                        f"validation_bus:K), sets (validation_bus, validation_bus:A..B) or CSV paths "
                        f"(default: {' '.join(bench.DEFAULT_CYCLES)})")
    p.add_argument("--task", default=None, metavar="NAME",
                   help=f"a benchmark task ({', '.join(list_tasks())}; a name alone is its newest version): its "
                        "cycles and scenario, instead of --cycles and --scenarios; its record goes to task.json")
    p.add_argument("--strategies", nargs="+", default=list(bench.DEFAULT_STRATEGIES), metavar="STRATEGY",
                   help=f"{strategies_help()}; {REFERENCE}, the reference of the ratios, is added if missing")
    p.add_argument("--family", action="append", default=[], metavar="NAME=PATH,PATH,...",
                   help=f"a seed family: at least {bench.MIN_SEEDS} trained runs (what ppo:PATH loads) of one training "
                        "setup, or one directory holding such runs; reported as the interquartile mean over the "
                        "seeds with a 95 %% bootstrap interval (repeat for several families)")
    p.add_argument("--scenarios", nargs="+", default=None, metavar="SCENARIO",
                   help=f"scenarios ({', '.join(list_scenarios())}) (default: {' '.join(bench.DEFAULT_SCENARIOS)})")
    p.add_argument("--out", default="results", metavar="DIR", help="output directory")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help=f"parallel processes, or CPUs of the local Ray runtime (default: the number of cores, "
                        f"{os.cpu_count() or 1} here)")
    p.add_argument("--executor", choices=EXECUTORS, default="local",
                   help="local: this machine's processes; ray: one Ray task per run (needs the ray extra)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="with --executor ray: join the Ray cluster at HOST:PORT (started with 'ray start --head') "
                        "instead of starting a local runtime")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")


def benchmark(args) -> int:
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    families, taken = [], set(list_strategies()) | set(args.strategies)
    for text in args.family:
        families.append(bench.parse_family(text, taken))
        taken.add(families[-1].name)
    if args.task is None:  # --task: its cycles and scenario
        task, cycles = None, args.cycles or list(bench.DEFAULT_CYCLES)
        scenarios = args.scenarios or list(bench.DEFAULT_SCENARIOS)
    elif args.cycles is not None or args.scenarios is not None:
        raise ValueError(f"--task {args.task} sets the cycles and the scenario; drop --cycles and --scenarios")
    else:
        task = get_task(args.task)
        if task.seeds != (0,) or task.start_s != 0:
            raise ValueError(f"--task {task.id}: the benchmark runs each cycle once from second 0 with seed 0; this "
                             f"task's episodes (seeds {list(task.seeds)}, start {task.start_s} s) need its own runner")
        cycles, scenarios = list(task.cycles), [task.scenario]
    out, t0 = Path(args.out), time.perf_counter()
    rows = bench.run_benchmark(out, expand_cycle_names(cycles), args.strategies, scenarios, jobs=args.jobs,
                         plots=not args.no_plots, executor=args.executor, address=args.address, families=families,
                         **({} if task is None else {"physics": task.physics}))
    if task is not None:
        atomic_write_json(out / "task.json", {**task.to_dict(), "digest": task.digest()})
        print(f"task {task.id}: {task.description}")
    print((out / "results.md").read_text())
    print(f"{sum(1 for r in rows if r.get('family') is None or r['family'] != r['strategy'])} runs in "
          f"{time.perf_counter() - t0:.1f} s")
    print(f"table: {out / 'results.md'} (also results.csv, results.json)")
    if not args.no_plots:
        print(f"plots: {out / FUEL_CHART_FILE}, {out}/traces_<cycle>_<scenario>.png")
    return 0


def paper_arguments(p) -> None:
    p.add_argument("--out", default="results/paper", metavar="DIR", help="output directory")
    p.add_argument("--cycles", nargs="+", default=["hwfet", "udds", "beijing"], metavar="CYCLE",
                   help="cycles for Table 2 and Figs. 7-10 (built-in names or CSV paths)")
    p.add_argument("--quick", action="store_true", help="reduced resolution (for tests and a quick look)")


def paper(args) -> int:
    try:
        from tools.paper.measure import table3_row
        from tools.paper.report import build_report
    except ModuleNotFoundError as exc:
        if exc.name not in ("tools", "tools.paper"):
            raise
        raise FileNotFoundError("evaluate.py paper runs from a source checkout of hev-thermal-env, where the report is "
                                "(tools/paper): run it there as python evaluate.py paper") from None
    out = check_writable_dir(args.out)
    for c in args.cycles:
        load_cycle(c)  # unknown names fail here, before any work
    data = build_report(out, cycles=tuple(args.cycles), quick=args.quick)
    off = table3_row(data["table3"], "off")
    print(f"Table 3 analog (thermal off): top {off['top_speed_kmh']:.1f} km/h, 0-60 {off['accel_0_60_s']:.2f} s, "
          f"grade {off['grade_4pct_speed_kmh']:.1f} km/h")
    for cyc, row in data["table2"].items():
        print(f"{cyc}: rule fuel {row['without_thermal']['fuel_l100']:.2f} -> "
              f"{row['with_thermal']['fuel_l100']:.2f} L/100 km with the thermal model")
    agr = data["agreement"]
    print(f"agreement: {agr['within']} of {agr['total']} paper figures within tolerance")
    print(f"wrote {out / 'report.md'} ({data['wall_s']:.1f} s)")
    return 0


def performance_arguments(p) -> None:
    p.add_argument("--json", metavar="PATH", help="write the figures as JSON here")
    p.add_argument("--config", metavar="YAML", help="vehicle config file (default: the built-in paper_bus)")
    p.add_argument("--no-thermal", action="store_true", help="thermal model off (the paper's ADVISOR baseline)")
    p.add_argument("--initial-motor-temp-c", type=float, default=20.0, metavar="T",
                   help="motor temperature at the start, °C")
    p.add_argument("--coolant", choices=list(COOLANT_MODES), default="on", help="coolant mode")
    p.add_argument("--ambient-temp-c", type=float, default=20.0, metavar="T", help="ambient temperature, °C")


def paper_row(thermal: bool, initial_motor_temp_c: float) -> tuple[str, str] | None:
    """Run and label of the paper's Table 3 row for these settings, or None when the paper has none."""
    if not thermal:
        return PAPER_ROWS[None]
    return next((row for t, row in PAPER_ROWS.items() if t is not None and math.isclose(initial_motor_temp_c, t)),
                None)


def performance(args) -> int:
    if args.json:
        check_output_path(args.json)
    config = VehicleConfig.from_yaml(args.config) if args.config else paper_bus()
    if args.no_thermal:
        config = config.with_thermal(False)
    cond = Conditions(ambient_temp_c=args.ambient_temp_c, initial_motor_temp_c=args.initial_motor_temp_c,
                      coolant=args.coolant)
    report = {k: round(float(v), 3) for k, v in performance_report(config, cond).items()}
    print(f"Vehicle performance (thermal model {'off' if args.no_thermal else 'on'}, motor starting at "
          f"{args.initial_motor_temp_c:g} °C, coolant {args.coolant})")
    row = paper_row(not args.no_thermal, args.initial_motor_temp_c)
    head = f"paper ({row[1]})" if row else "paper (no row for these settings)"
    print(f"  {'figure':<20}{'value':>10}  {'unit':<6}{head:>36}")
    for name, key, unit in FIGURES:
        paper = f"{table3_paper(row[0])[key]:.1f}" if row else "-"
        print(f"  {name:<20}{report[key]:>10.2f}  {unit:<6}{paper:>36}")
    if args.json:
        atomic_write_json(args.json, report)
        print(f"wrote {args.json}")
    return 0


COMMANDS = {
    "benchmark": ("every strategy on every cycle and scenario: table + plots",
                  "Run every strategy on every cycle in every scenario; write results.csv, results.json, results.md, "
                  "timings.json and PNG plots into --out. Every run is measured against the thermal optimum "
                  f"{REFERENCE} of its cycle and scenario (frontier ratio, fixed-price ratio); dp is thermal-blind.",
                  BENCHMARK_EXAMPLES, benchmark_arguments, benchmark),
    "run": ("one strategy on one cycle: summary, JSON, trace CSV, plot",
            "Drive one cycle with one energy-management strategy in HevThermal-v2 and report fuel, corrected fuel, "
            "SOC, motor temperature, heat index, derating and cutoff time.", RUN_EXAMPLES, run_arguments, run),
    "paper": ("paper reproduction report (markdown + PNG)",
              "Our results beside the paper's Tables 2-3 and Figs. 4, 7-10: report.md, paper.json and the figures, "
              "written into --out.",
              ("python evaluate.py paper --out results/paper",
               "python evaluate.py paper --cycles hwfet beijing --out results/paper",
               "python evaluate.py paper --quick --out /tmp/paper             # reduced resolution, a quick look"),
              paper_arguments, paper),
    "performance": ("vehicle performance tests (paper Table 3)",
                    "Top speed, 0-60 km/h time and 4 % grade speed of the bus, each beside the paper's value for the "
                    "same row of its Table 3.",
                    PERFORMANCE_EXAMPLES, performance_arguments, performance),
}
