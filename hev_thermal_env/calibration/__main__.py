"""``python -m hev_thermal_env.calibration --out DIR``: fit, then write ``DIR/fitted_params.yaml`` (a partial
``VehicleConfig``: ``VehicleConfig.from_yaml`` gives ``paper_bus`` with these thermal values), ``DIR/residuals.md``
and ``DIR/residuals.json``."""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path
from typing import Any

from ..physics import paper_bus, thermal
from . import fit as F
from . import report as R


def write_defaults(values: dict[str, float]) -> Path:
    """Replace the default of each fitted field in ``physics/thermal.py`` (the value after ``spec(``)."""
    path = Path(thermal.__file__)
    text = path.read_text()
    for name, value in values.items():
        match = re.search(r"(    " + re.escape(name) + r": float = spec\(\n\s+)([^,\s]+)(,)", text)
        if match is None:
            raise ValueError(f"ThermalParams.{name}: no 'spec(' with the default on the next line in {path}")
        text = text[:match.start(2)] + repr(float(value)) + text[match.end(2):]
    path.write_text(text)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hev_thermal_env.calibration", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--seed", type=int, default=11, help="seed of the differential evolution stages")
    ap.add_argument("--de-maxiter", type=int, default=30, help="generations per differential evolution stage")
    ap.add_argument("--no-fit", action="store_true", help="report the current defaults without fitting")
    ap.add_argument("--check", action="store_true", help="exit 1 if the fit differs from ThermalParams's defaults")
    ap.add_argument("--write-defaults", action="store_true",
                    help="write the fitted values into ThermalParams's defaults (physics/thermal.py)")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, flush=True))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if args.no_fit:
        values = {n: float(getattr(paper_bus().thermal, n)) for n in F.NETWORK_PARAMS + F.CLOSURE_PARAMS}
        stages: list[Any] = []
    else:
        result = F.run_fit(seed=args.seed, de_maxiter=args.de_maxiter, progress=say)
        values, stages = result.values, result.stages
    report = R.build(values, stages=stages)
    report["wall_s"] = time.perf_counter() - t0
    (out / "fitted_params.yaml").write_text(R.params_yaml(values))
    (out / "residuals.md").write_text(R.residuals_markdown(report))
    (out / "residuals.json").write_text(json.dumps(report, indent=2, default=float) + "\n")
    say(R.residuals_markdown(report))
    say(f"wrote {out / 'fitted_params.yaml'}, {out / 'residuals.md'}, {out / 'residuals.json'} "
        f"({report['wall_s']:.0f} s)")
    if args.write_defaults:
        say(f"wrote the fitted values into {write_defaults(values)}")
    if args.check:
        defaults = paper_bus().thermal
        diff = {k: (getattr(defaults, k), v) for k, v in values.items() if getattr(defaults, k) != v}
        if diff:
            print("fitted values differ from ThermalParams's defaults: "
                  + ", ".join(f"{k}: default {a!r}, fitted {b!r}" for k, (a, b) in diff.items()), file=sys.stderr)
            return 1
        say("ThermalParams's defaults hold the fitted values")
    return 0


if __name__ == "__main__":
    sys.exit(main())
