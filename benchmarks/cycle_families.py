#!/usr/bin/env python
"""Statistics of the cycle families and of the validation set (docs/cycle-families.md).

``python benchmarks/cycle_families.py`` generates ``--seeds`` cycles of every family (seeds drawn as
training draws them, :func:`~hev_thermal_env.cycles.families.training_seed`), measures each with
:func:`~hev_thermal_env.cycles.cycle_statistics` and writes min / mean / max per family and statistic,
whether every cycle lies within the documented bounds (``FAMILY_BOUNDS``, ``tools/family_bounds.py``), and the
statistics of each validation cycle, to ``benchmarks/results/cycle_families.json``; ``--figure`` draws one cycle of each
family (speed and grade) to ``docs/cycle_families.png``. It prints the docs page's table.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout: its workshop (tools/)

from hev_thermal_env.cycles import (  # noqa: E402
    cycle_statistics,
    expand_cycle_names,
    generate_family_cycle,
    list_families,
    load_cycle,
)
from hev_thermal_env.cycles.families import PAYLOAD_KG_RANGE, training_seed  # noqa: E402
from tools.family_bounds import FAMILY_BOUNDS  # noqa: E402

COLUMNS = (("duration_s", "duration (s)", "{:.0f}"), ("mean_speed_kmh", "mean speed (km/h)", "{:.1f}"),
           ("max_speed_kmh", "max speed (km/h)", "{:.0f}"), ("stops_per_km", "stops per km", "{:.1f}"),
           ("idle_fraction", "idle share", "{:.2f}"), ("max_accel_mps2", "max accel (m/s²)", "{:.2f}"),
           ("grade_min", "grade min", "{:+.3f}"), ("grade_max", "grade max", "{:+.3f}"))


def measure(n_seeds: int, seed: int) -> dict:
    """Statistics of ``n_seeds`` cycles per family and of every validation cycle."""
    rng = np.random.default_rng(seed)
    families = {}
    for family in list_families():
        rows = [cycle_statistics(generate_family_cycle(family, training_seed(rng, family))) for _ in range(n_seeds)]
        stats = {k: {"min": float(np.min([r[k] for r in rows])), "mean": float(np.mean([r[k] for r in rows])),
                     "max": float(np.max([r[k] for r in rows]))} for k in rows[0]}
        bounds = FAMILY_BOUNDS[family]
        inside = all(lo - 1e-4 <= r[k] <= hi + 1e-4 for r in rows for k, (lo, hi) in bounds.items())
        families[family] = {"cycles": n_seeds, "statistics": stats, "bounds": {k: list(v) for k, v in bounds.items()},
                            "all_within_bounds": inside, "payload_kg_range": list(PAYLOAD_KG_RANGE)}
    validation = {}
    for name in expand_cycle_names("validation_bus"):
        cyc = load_cycle(name)
        validation[name] = {"family": cyc.metadata["family"], "seed": cyc.metadata["seed"], **cycle_statistics(cyc)}
    return {"families": families, "validation": validation}


def table(report: dict) -> str:
    """The docs table: per family, each statistic as min-max over the generated cycles (mean)."""
    head = "| family | " + " | ".join(label for _, label, _ in COLUMNS) + " |"
    lines = [head, "|" + "---|" * (len(COLUMNS) + 1)]
    for family, data in report["families"].items():
        cells = []
        for key, _, fmt in COLUMNS:
            s = data["statistics"][key]
            lo, hi = fmt.format(s["min"]), fmt.format(s["max"])
            cells.append(lo if lo == hi else f"{lo} – {hi} ({fmt.format(s['mean'])})")
        lines.append(f"| `{family}` | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure(path: Path) -> None:
    """One cycle of each family: speed (left axis) and grade (right axis, where there is one)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    families = list_families()
    fig, axes = plt.subplots(len(families), 1, figsize=(11, 2.0 * len(families)), layout="constrained")
    for ax, family in zip(axes, families):
        cyc = generate_family_cycle(family, 1)
        t = np.asarray(cyc.time_s)
        ax.plot(t, 3.6 * np.asarray(cyc.speed_mps), lw=0.6, color="C0")
        ax.set_ylabel("km/h")
        ax.set_xlim(0, 4500)
        ax.set_ylim(0, 120 if cyc.max_speed_kmh > 75 else 75)
        ax.set_title(f"{cyc.name}: {cyc.duration_s:.0f} s, mean {cyc.mean_speed_kmh:.1f} km/h, "
                     f"max accel {np.diff(cyc.speed_mps).max():.2f} m/s²", fontsize=9, loc="left")
        if np.any(np.asarray(cyc.grade) != 0.0):
            twin = ax.twinx()
            twin.plot(t, 100 * np.asarray(cyc.grade), lw=0.8, color="C3")
            twin.set_ylabel("grade %", color="C3")
            twin.set_ylim(-9, 9)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("One generated cycle of each family (seed 1): speed (blue), grade (red, right axis)", fontsize=11)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=300, help="cycles per family")
    ap.add_argument("--seed", type=int, default=0, help="seed of the seed draws")
    ap.add_argument("--json", default="benchmarks/results/cycle_families.json")
    ap.add_argument("--figure", default=None, metavar="PNG", help="also draw one cycle per family here")
    args = ap.parse_args()
    t0 = time.perf_counter()
    report = measure(args.seeds, args.seed)
    report["wall_s"] = round(time.perf_counter() - t0, 2)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=2) + "\n")
    if args.figure:
        figure(Path(args.figure))
    print(table(report))
    bad = [f for f, d in report["families"].items() if not d["all_within_bounds"]]
    print(f"{args.seeds} cycles per family, {len(report['validation'])} validation cycles in {report['wall_s']} s; "
          f"outside the documented bounds: {', '.join(bad) or 'none'}; wrote {args.json}")


if __name__ == "__main__":
    main()
