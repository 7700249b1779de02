"""``evaluate.py performance``: top speed, 0-60 km/h and 4 % grade speed (the paper's Table 3).

Each figure is printed beside the paper's value for the same row of Table 3: thermal model off,
or on with the motor starting at 30 °C or 50 °C (the paper ran those with the coolant closed).
Other starting temperatures have no paper row; their comparison column is left empty.
"""

from __future__ import annotations

import argparse
import math

from hev_thermal_env.io import atomic_write_json, check_output_path
from hev_thermal_env.paper.figures import table3_paper
from hev_thermal_env.physics import Conditions, VehicleConfig, paper_bus
from hev_thermal_env.physics.config import COOLANT_MODES
from hev_thermal_env.physics.performance import performance_report

EXAMPLES = (
    "python evaluate.py performance --no-thermal --json results/performance.json   # paper: thermal off",
    "python evaluate.py performance --initial-motor-temp-c 30 --coolant off         # paper: 30 °C start",
    "python evaluate.py performance --initial-motor-temp-c 50 --coolant off         # paper: 50 °C start",
    "python evaluate.py performance --config my_bus.yaml",
)

#: The paper's rows of Table 3 (a run of :data:`~hev_thermal_env.paper.figures.TABLE3_RUNS`) by starting temperature.
PAPER_ROWS = {None: ("off", "thermal off"), 30.0: ("30c", "30 °C start, coolant closed"),
              50.0: ("50c", "50 °C start, coolant closed")}
FIGURES = (("top speed", "top_speed_kmh", "km/h"), ("0-60 km/h", "accel_0_60_s", "s"),
           ("speed on 4 % grade", "grade_4pct_speed_kmh", "km/h"))

HELP = "vehicle performance tests (paper Table 3)"
DESCRIPTION = ("Top speed, 0-60 km/h time and 4 % grade speed of the bus, each beside the "
               "paper's value for the same row of its Table 3.")


def add_arguments(p: argparse.ArgumentParser) -> None:
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


def main(args: argparse.Namespace) -> int:
    if args.json:
        check_output_path(args.json)
    config = VehicleConfig.from_yaml(args.config) if args.config else paper_bus()
    if args.no_thermal:
        config = config.with_thermal(False)
    cond = Conditions(ambient_temp_c=args.ambient_temp_c, initial_motor_temp_c=args.initial_motor_temp_c,
                      coolant=args.coolant)
    report = {k: round(float(v), 3) for k, v in performance_report(config, cond).items()}
    thermal = "off" if args.no_thermal else "on"
    print(f"Vehicle performance (thermal model {thermal}, motor starting at {args.initial_motor_temp_c:g} °C, "
          f"coolant {args.coolant})")
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
