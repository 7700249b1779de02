"""``evaluate.py paper`` (the paper reproduction report) and ``evaluate.py performance`` (top speed, 0-60 km/h and 4 %
grade speed, the paper's Table 3).

The report is the maintainers' comparison of the model with the figures it was calibrated to; it lives in the
workshop of a source checkout, ``tools/paper`` (docs/development.md), and is imported only when the command runs.
Each performance figure is printed beside the paper's value for the same row of Table 3: thermal model off, or on
with the motor starting at 30 °C or 50 °C (the paper ran those with the coolant closed); other starting temperatures
have no paper row, their comparison column is left empty.
"""

from __future__ import annotations

import math

from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.io import atomic_write_json, check_output_path, check_writable_dir
from hev_thermal_env.paper.figures import table3_paper
from hev_thermal_env.physics import Conditions, VehicleConfig, paper_bus
from hev_thermal_env.physics.config import COOLANT_MODES
from hev_thermal_env.physics.performance import performance_report

#: The paper's rows of Table 3 (a run of :data:`~hev_thermal_env.paper.figures.TABLE3_RUNS`) by starting temperature.
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
