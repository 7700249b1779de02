"""``evaluate.py paper``: the paper reproduction report.

The report is the maintainers' comparison of the model with the figures it was calibrated to; it lives in the
workshop of a source checkout, ``tools/paper`` (docs/development.md), and is imported only when the command runs.
"""

from __future__ import annotations

import argparse

from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.io import check_writable_dir

EXAMPLES = (
    "python evaluate.py paper --out results/paper",
    "python evaluate.py paper --cycles hwfet beijing --out results/paper",
    "python evaluate.py paper --quick --out /tmp/paper             # reduced resolution, a quick look",
)

HELP = "paper reproduction report (markdown + PNG)"
DESCRIPTION = ("Our results beside the paper's Tables 2-3 and Figs. 4, 7-10: report.md, "
               "paper.json and the figures, written into --out.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="results/paper", metavar="DIR", help="output directory")
    p.add_argument("--cycles", nargs="+", default=["hwfet", "udds", "beijing"], metavar="CYCLE",
                   help="cycles for Table 2 and Figs. 7-10 (built-in names or CSV paths)")
    p.add_argument("--quick", action="store_true", help="reduced resolution (for tests and a quick look)")


def main(args: argparse.Namespace) -> int:
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
