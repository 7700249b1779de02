"""The fit log, docs/calibration/fit_log.md: every attempt of the protocol's fit appended, never rewritten.

Each entry records the date, the commit the fit ran on (and whether the tree had uncommitted changes), the
protocol's commit, the optimiser settings, every start, the values with their distances from the bounds, the
singular values, condition number and right singular vectors, the profiles, every fitted **and** held-out residual,
the wall time, and whether the attempt was adopted (protocol.md, §4).
"""

from __future__ import annotations

import datetime
import math
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tools.paper.figures import FITTED, HELD_OUT

from .fit import Attempt
from .protocol import PROTOCOL_MD, PROTOCOL_YAML

FIT_LOG = PROTOCOL_YAML.with_name("fit_log.md")
HEADER = ("# Thermal calibration: fit log\n\n"
          "Every attempt of the protocol's fit (protocol.md, §4), appended by `python -m tools.calibration` "
          "and never edited. Residuals r in tolerances (|r| ≤ 1 meets a target); held-out targets are measured after "
          "each attempt and never enter a cost. Unit coordinates θ̃ are in [0, 1] (logarithmic for the two "
          "conductances).\n")


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=PROTOCOL_YAML.parent, capture_output=True, text=True,
                              check=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def provenance() -> dict[str, str]:
    """Date (UTC), HEAD commit, uncommitted changes, and the last commit of the protocol's two files."""
    dirty = _git("status", "--porcelain", "--untracked-files=no")
    return {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "commit": _git("rev-parse", "HEAD") or "unknown",
            "uncommitted_changes": "yes" if dirty else "no",
            "protocol_commit": _git("log", "-1", "--format=%H", "--", str(PROTOCOL_MD), str(PROTOCOL_YAML))
            or "unknown"}


def _g(x: float, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return f"{x:.{digits}g}"


def _vec(xs: Sequence[float], digits: int = 3) -> str:
    return "(" + ", ".join(f"{x:.{digits}f}" for x in xs) + ")"


def residual_lines(measured: dict[str, float], residuals: dict[str, float]) -> list[str]:
    lines = ["| id | group | quantity | paper | ours | r | met |", "|---|---|---|---|---|---|---|"]
    for t in FITTED + HELD_OUT:
        v, r = measured.get(t.name), residuals.get(t.name)
        lines.append(f"| {t.id} | {t.group.replace('_', ' ')} | {t.description} | {t.paper_text()} | {_g(v)} | "
                     f"{_g(r, 3)} | {'yes' if t.within(v) else '**no**'} |")
    return lines


def _starts_lines(a: Attempt) -> list[str]:
    names = a.free
    lines = [f"Starts ({len(a.starts)}; unit coordinates of {', '.join(names) or 'nothing'}):", "",
             "| start | θ̃ start | θ̃ end | values at the end | Σr² | model runs | stop |",
             "|---|---|---|---|---|---|---|"]
    for i, s in enumerate(a.starts):
        vals = ", ".join(f"{_g(s.values[n])}" for n in names)
        mark = " **(best)**" if i == a.best else ""
        lines.append(f"| {s.label}{mark} | {_vec(s.x0)} | {_vec(s.x)} | {vals} | {s.cost:.4f} | {s.evaluations} | "
                     f"{s.message.rstrip('.')} |")
    return lines


def identifiability_lines(a: Attempt) -> list[str]:
    idf = a.identifiability
    if not a.free:
        return ["No free parameter: nothing to identify."]
    lines = ["| parameter | value | θ̃ | distance from bounds | local s.e. (physical) | s.e. (θ̃) | Jacobian step |",
             "|---|---|---|---|---|---|---|"]
    for j, n in enumerate(a.free):
        flag = " **< 0.05**" if idf["near_bound"][j] else ""
        lines.append(f"| `{n}` | {_g(a.values[n])} | {a.x[j]:.3f} | {idf['distance_from_bounds'][j]:.3f}{flag} | "
                     f"{_g(idf['se_physical'][j], 3)} | {_g(idf['se_unit'][j], 3)} | {idf['steps'][j]} |")
    sv = idf["singular_values"]
    lines += ["", f"Singular values of ∂r/∂θ̃: {', '.join(f'{s:.4g}' for s in sv)}; condition number "
              f"{idf['condition_number']:.4g}; smallest/largest {sv[-1] / sv[0]:.3g}.", "",
              "Right singular vectors (rows, in the order of the singular values; components "
              f"{', '.join(a.free)}): " + "; ".join(_vec(v, 3) for v in idf["vt"]) + "."]
    return lines


def profile_lines(a: Attempt) -> list[str]:
    if not a.profiles:
        return ["Profiles: not computed in this attempt."]
    lines = ["Profiles (Δ(Σr²) from the fit's Σr² at the grid points, the others re-optimised):", "",
             "| parameter | grid | Δ at the grid points | identified low / high | flat | lowest Δ (at) |",
             "|---|---|---|---|---|---|"]
    for p in a.profiles:
        deltas = " ".join(f"{d:.2f}" for d in p["delta"])
        lines.append(f"| `{p['name']}` | {_g(p['grid_values'][0])}-{_g(p['grid_values'][-1])}, "
                     f"{len(p['grid_unit'])} points | {deltas} | {'yes' if p['identified_low'] else 'no'} / "
                     f"{'yes' if p['identified_high'] else 'no'} | {'**yes**' if p['flat'] else 'no'} | "
                     f"{p['below_fit']:.3f} ({_g(p['argmin_value'])}) |")
    return lines


def attempt_markdown(a: Attempt, prov: dict[str, str], index: int, extra: str = "") -> str:
    s = a.settings
    fixed = ", ".join(f"`{k}` = {_g(v)} (documented start)" for k, v in a.fixed.items()) or "none"
    lines = [f"## Attempt {index}: {a.label} ({'**adopted**' if a.adopted else 'not adopted'})", "",
             f"* Date {prov['date']}; commit `{prov['commit'][:12]}` (uncommitted changes: "
             f"{prov['uncommitted_changes']}); protocol commit `{prov['protocol_commit'][:12]}`.",
             f"* Free: {', '.join(f'`{n}`' for n in a.free) or 'none'}; fixed by the fallback: {fixed}.",
             f"* Settings: least_squares trf, 2-point Jacobian, diff_step {s['diff_step']}, ftol {s['ftol']}, "
             f"xtol {s['xtol']}, gtol {s['gtol']}, max_nfev {s['max_nfev']} per start; documented start + "
             f"{s['n_sobol']} Sobol points (scrambled, seed {s['seed']}); identifiability Jacobian step "
             f"{s['jac_step']}; profiles {s['profile_points']} points, max_nfev {s['profile_max_nfev']} per point.",
             f"* Result: Σr² = {a.cost:.4f} over F1-F7; {a.evaluations} model runs; wall time {a.wall_s:.0f} s. "
             f"{a.note}.", *([f"* {extra}"] if extra else []), "",
             *_starts_lines(a), "", *identifiability_lines(a), "", *profile_lines(a), "",
             "Residuals at this attempt's best fit (fitted and held out):", "",
             *residual_lines(a.measured, a.residuals), ""]
    return "\n".join(lines) + "\n"


def append(attempts: Sequence[Attempt], path: Path = FIT_LOG, prov: dict[str, str] | None = None,
           extra: str = "") -> Path:
    """Append every attempt to the fit log (created with its header if absent), numbered after those there."""
    prov = prov or provenance()
    text = path.read_text() if path.is_file() else HEADER
    n = text.count("\n## Attempt ")
    text = text.rstrip("\n") + "\n\n" + "\n".join(attempt_markdown(a, prov, n + i + 1, extra)
                                                  for i, a in enumerate(attempts))
    path.write_text(text)
    return path


def attempt_record(a: Attempt) -> dict[str, Any]:
    """The attempt as plain data (for the committed fit result)."""
    import dataclasses

    return dataclasses.asdict(a)
