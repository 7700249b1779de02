"""``python -m tools.calibration``: the protocol's fit (:mod:`.fit`), every attempt appended to the fit log
(:mod:`.log`), then ``fitted_params.yaml``, ``fit_result.json``, ``residuals.md`` and ``residuals.json`` in
``--out`` (default docs/calibration/). ``--report-only`` writes the residuals of the current defaults without
fitting; ``--check`` fails if ``ThermalParams``'s defaults differ from the committed ``fitted_params.yaml``;
``--write-docs`` rewrites the generated tables of docs/thermal_model.md (:mod:`.docs`)."""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

import yaml

from hev_thermal_env.physics import paper_bus, thermal

from . import fit, log
from . import protocol as proto
from . import report as residual_report

OUT = proto.PROTOCOL_YAML.parent


def write_defaults(values: dict[str, float]) -> Path:
    """Replace the default of each fitted field in ``physics/thermal.py`` (the number after ``spec(``)."""
    path = Path(thermal.__file__)
    text = path.read_text()
    for name, value in values.items():
        _, field = proto.field_of(name)
        match = re.search(r"(    " + re.escape(field.name) + r": float = spec\(\s*)([-+0-9.eE]+)(,)", text)
        if match is None:
            raise ValueError(f"{path}: ThermalParams.{field.name}: no 'spec(' followed by its default")
        text = text[:match.start(2)] + repr(float(value)) + text[match.end(2):]
    path.write_text(text)
    return path


def run_fit(args: argparse.Namespace, out: Path) -> dict[str, float]:
    settings = fit.Settings(max_nfev=args.max_nfev, profile_points=args.profile_points, n_sobol=args.n_sobol)
    t0 = time.perf_counter()
    prov = log.provenance()  # the tree the fit runs on, before anything is written
    attempts = fit.calibrate(settings, with_profiles=not args.no_profiles, progress=not args.quiet)
    adopted = attempts[-1]
    values = {p.name: fit.round_sig(adopted.values[p.name]) for p in proto.fitted_parameters()}
    extra = ("Values written to the code (5 significant digits: F1's onset jumps between crossings): "
             + ", ".join(f"`{k}` = {v:g}" for k, v in values.items()) + f". Total wall time "
             f"{time.perf_counter() - t0:.0f} s." + (f" {args.note}" if args.note else ""))
    if not args.no_log:
        log.append(attempts, prov=prov, extra=extra)
    best = adopted.starts[adopted.best]
    meta = {"attempt": adopted.label, "free": adopted.free, "fixed": adopted.fixed, "best_start": best.label,
            "start_unit": best.x0, "x_unit": adopted.x, "cost": adopted.cost, "settings": adopted.settings}
    (out / "fitted_params.yaml").write_text(residual_report.params_yaml(values, meta))
    (out / "fit_result.json").write_text(json.dumps([log.attempt_record(a) for a in attempts], indent=1,
                                                    default=float) + "\n")
    return values


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.calibration", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(OUT), help="output directory (default: docs/calibration)")
    ap.add_argument("--report-only", action="store_true", help="no fit: the residuals of the current defaults")
    ap.add_argument("--max-nfev", type=int, default=fit.Settings.max_nfev, help="least_squares max_nfev per start")
    ap.add_argument("--profile-points", type=int, default=fit.Settings.profile_points, help="points per profile")
    ap.add_argument("--n-sobol", type=int, default=fit.Settings.n_sobol, help="Sobol starts besides the documented one")
    ap.add_argument("--no-profiles", action="store_true", help="skip the profiles (the fallback's second rule too)")
    ap.add_argument("--no-log", action="store_true", help="do not append to docs/calibration/fit_log.md")
    ap.add_argument("--note", default="", help="a sentence appended to this run's fit-log entry")
    ap.add_argument("--write-defaults", action="store_true", help="write the fitted values into ThermalParams")
    ap.add_argument("--check", action="store_true", help="exit 1 if ThermalParams's defaults differ from the fit")
    ap.add_argument("--write-docs", action="store_true", help="rewrite the generated tables of docs/thermal_model.md")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, flush=True))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    config = paper_bus()
    if not args.report_only:
        values = run_fit(args, out)
        config = proto.with_values(config, values)
        if args.write_defaults:
            say(f"wrote the fitted values into {write_defaults(values)}")
    report = residual_report.build(config)
    (out / "residuals.md").write_text(residual_report.residuals_markdown(report))
    (out / "residuals.json").write_text(json.dumps(report, indent=1, default=float) + "\n")
    say(residual_report.residuals_markdown(report))
    if args.write_docs:
        from . import docs

        say(f"rewrote the generated tables of {docs.write()}")
    if args.check:
        committed = yaml.safe_load((out / "fitted_params.yaml").read_text())["thermal"]
        diff = {k: (proto.value_in_code(k), v) for k, v in committed.items() if proto.value_in_code(k) != v}
        if diff:
            print("ThermalParams's defaults differ from fitted_params.yaml: "
                  + ", ".join(f"{k}: default {a!r}, fitted {b!r}" for k, (a, b) in diff.items()), file=sys.stderr)
            return 1
        say("ThermalParams's defaults hold the fitted values")
    return 0


if __name__ == "__main__":
    sys.exit(main())
