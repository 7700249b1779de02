"""``evaluate.py performance``: top speed, 0-60 km/h and 4 % grade speed (the paper's Table 3)."""

from __future__ import annotations

import argparse

from hev_thermal_env.io import atomic_write_json, check_output_path
from hev_thermal_env.physics import Conditions, VehicleConfig, paper_bus
from hev_thermal_env.physics.performance import performance_report


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("performance", help="vehicle performance tests (paper Table 3)",
                       description="Top speed, 0-60 km/h time and 4 %% grade speed of the bus.")
    p.add_argument("--json", metavar="PATH", help="write the figures as JSON here")
    p.add_argument("--config", metavar="YAML", help="vehicle config (default: paper_bus)")
    p.add_argument("--no-thermal", action="store_true", help="thermal model off (the paper's ADVISOR baseline)")
    p.add_argument("--initial-motor-temp-c", type=float, default=20.0, metavar="T",
                   help="motor temperature at the start (default 20)")
    p.add_argument("--coolant", choices=["on", "degraded", "off"], default="on", help="coolant mode (default on)")
    p.add_argument("--ambient-temp-c", type=float, default=20.0, metavar="T", help="ambient temperature (default 20)")


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
    rows = [("top speed", report["top_speed_kmh"], "km/h", 89.0),
            ("0-60 km/h", report["accel_0_60_s"], "s", 16.4),
            ("speed on 4 % grade", report["grade_4pct_speed_kmh"], "km/h", 48.3)]
    print(f"  {'figure':<20}{'value':>10}  {'unit':<6}{'paper (thermal off)':>22}")
    for name, value, unit, paper in rows:
        print(f"  {name:<20}{value:>10.2f}  {unit:<6}{paper:>22.1f}")
    if args.json:
        atomic_write_json(args.json, report)
        print(f"wrote {args.json}")
    return 0
