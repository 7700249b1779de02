#!/usr/bin/env python
"""Figures and tables of docs/thermal_model.md: the calibrated network against the paper's equations,
DP in the paper scenario, and thermal-blind vs thermal-aware ECMS where heat matters.

``python benchmarks/thermal_scenarios.py --out docs/thermal`` writes ``thermal_scenarios.json``,
``thermal_scenarios.md`` and the PNG figures. Every run goes through the evaluation runner
(``run_strategy``), so it is the environment's own run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from hev_thermal_env import paper_bus
from hev_thermal_env.scenarios import get_scenario

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout: its workshop, tools/

from tools.paper.figures import PAPER_FIGURE_BY_NAME as P  # noqa: E402

CYCLES = ("hwfet", "udds", "beijing")
SCENARIOS = ("paper", "summer", "hilly", "full_bus", "hot")


def _runner():
    from hev_thermal_env.evaluation.runner import run_strategy
    return run_strategy


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def paper_figures(out: Path) -> dict:
    """Figs 7-10 analogs: rule strategy, paper scenario, network vs the paper's equations as written."""
    from hev_thermal_env.agents import get_strategy

    run = _runner()
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(15, 6.5), sharex="col")
    data = {}
    for j, cyc in enumerate(CYCLES):
        tr = {label: run(get_strategy("rule"), cyc, "paper", config=cfg).trace
              for label, cfg in (("network", paper_bus()), ("paper_eqs", paper_bus("paper_eqs")))}
        t = np.arange(1, len(tr["network"]["motor_temp_c"]) + 1)
        ax = axes[0, j]
        ax.plot(t, tr["network"]["motor_temp_c"], lw=0.9, label="network: motor (stator/housing)")
        ax.plot(t, tr["network"]["winding_temp_c"], lw=0.9, label="network: winding")
        ax.plot(t, tr["network"]["coolant_temp_c"], lw=0.9, label="network: coolant")
        ax.plot(t, tr["paper_eqs"]["motor_temp_c"], lw=0.9, ls="--", color="k", label="paper's eqs as written")
        if cyc == "udds":
            peak, last = P["udds_temp_peak_c"].paper, P["udds_temp_last300_c"].paper
            ax.axhline(peak, color="tab:red", lw=0.6, ls=":", label=f"paper: peak {peak:g}, settles {last:g} °C")
            ax.axhline(last, color="tab:red", lw=0.6, ls=":")
        if cyc == "beijing":
            warm = P["beijing_temp_warm_mean_c"].paper
            ax.axhline(warm, color="tab:red", lw=0.6, ls=":", label=f"paper: ≈{warm:g} °C")
        ax.set_title(f"{cyc}: rule strategy, paper scenario")
        ax.set_ylabel("temperature (°C)")
        ax.legend(fontsize=7, loc="lower right")
        ax = axes[1, j]
        ax.plot(t, tr["network"]["heat_index"], lw=0.9, label="network")
        ax.plot(t, tr["paper_eqs"]["heat_index"], lw=0.9, ls="--", color="k", label="paper's eqs as written")
        if cyc == "udds":
            onset, hi_peak = P["udds_hi_onset_s"].paper, P["udds_hi_peak"].paper
            ax.axvline(onset, color="tab:red", lw=0.6, ls=":", label=f"paper: from {onset:g} s to ≈{hi_peak:g}")
            ax.axhline(hi_peak, color="tab:red", lw=0.6, ls=":")
        ax.set_ylim(-0.02, 1.0)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("heat index PWM (-)")
        ax.legend(fontsize=7)
        data[cyc] = {k: {"temp_max_c": float(v["motor_temp_c"].max()), "heat_index_max": float(v["heat_index"].max())}
                     for k, v in tr.items()}
    fig.tight_layout()
    fig.savefig(out / "paper_figures_rule.png", dpi=90)
    plt.close(fig)
    return data


def dp_ranges(out: Path) -> dict:
    """DP (thermal-blind plan, executed in the thermal environment) in the paper scenario."""
    from hev_thermal_env.agents import get_strategy

    run = _runner()
    res = {}
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.4))
    for j, cyc in enumerate(CYCLES):
        t0 = time.perf_counter()
        r = run(get_strategy("dp"), cyc, "paper")
        tr = r.trace
        res[cyc] = {"temp_min_c": float(tr["motor_temp_c"].min()), "temp_max_c": float(tr["motor_temp_c"].max()),
                    "temp_std_c": float(tr["motor_temp_c"].std()),
                    "heat_index_min": float(tr["heat_index"].min()), "heat_index_max": float(tr["heat_index"].max()),
                    "heat_x_min": float(tr["heat_x"].min()), "heat_x_max": float(tr["heat_x"].max()),
                    "derated_s": r.summary["derated_s"], "cutoff_s": r.summary["cutoff_s"],
                    "fuel_corrected_l_per_100km": r.summary["fuel_corrected_l_per_100km"],
                    "wall_s": time.perf_counter() - t0}
        ax = axes[j]
        t = np.arange(1, len(tr["motor_temp_c"]) + 1)
        ax.plot(t, tr["motor_temp_c"], lw=0.8, label="motor temperature")
        ax.set_ylabel("motor temperature (°C)")
        ax2 = ax.twinx()
        ax2.plot(t, tr["heat_x"], lw=0.8, color="tab:orange", label="heat-index integrator x")
        ax2.plot(t, tr["heat_index"], lw=0.8, color="tab:red", label="heat index PWM = clip(x, 0, 1)")
        ax2.set_ylim(-0.65, 1.0)
        ax2.set_ylabel("heat index (-)")
        ax2.legend(fontsize=7, loc="lower right")
        ax.set_title(f"dp, {cyc}, paper scenario")
        ax.set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(out / "dp_paper_scenario.png", dpi=90)
    plt.close(fig)
    return res


def ecms_table() -> list[dict]:
    """Thermal-blind ``ecms`` vs ``ecms_thermal`` where heat matters (and the paper scenario for reference)."""
    from hev_thermal_env.agents import get_strategy

    run = _runner()
    rows = []
    for scen in SCENARIOS:
        sc = get_scenario(scen)
        for cyc in CYCLES:
            c = sc.prepare_cycle(cyc)
            row = {"scenario": scen, "cycle": cyc}
            for name in ("ecms", "ecms_thermal"):
                s = run(get_strategy(name), c, sc).summary
                row[name] = {k: s[k] for k in ("derated_s", "cutoff_s", "max_motor_temp_c", "heat_index_max",
                                               "fuel_corrected_l_per_100km", "missed_wheel_energy_kwh")}
            rows.append(row)
            print(scen, cyc, row["ecms"]["derated_s"], row["ecms_thermal"]["derated_s"], row["ecms"]["cutoff_s"],
                  row["ecms_thermal"]["cutoff_s"], flush=True)
    return rows


def markdown(data: dict) -> str:
    lines = ["## DP in the paper scenario (thermal-blind plan, thermal environment)", "",
             "| cycle | motor temperature min-max (°C) | std (°C) | heat index PWM min-max | integrator x min-max | "
             "derated (s) | cut off (s) | corrected fuel (L/100 km) |", "|---|---|---|---|---|---|---|---|"]
    for cyc, r in data["dp"].items():
        lines.append(f"| {cyc} | {r['temp_min_c']:.1f}-{r['temp_max_c']:.1f} | {r['temp_std_c']:.1f} | "
                     f"{r['heat_index_min']:.2f}-{r['heat_index_max']:.2f} | "
                     f"{r['heat_x_min']:.2f} to {r['heat_x_max']:.2f} | "
                     f"{r['derated_s']:.0f} | "
                     f"{r['cutoff_s']:.0f} | {r['fuel_corrected_l_per_100km']:.2f} |")
    lines += ["", "## Thermal-blind `ecms` against `ecms_thermal`", "",
              "| scenario | cycle | derated (s) ecms / ecms_thermal | cut off (s) ecms / ecms_thermal | "
              "max motor temperature (°C) | heat-index peak | corrected fuel (L/100 km) |",
              "|---|---|---|---|---|---|---|"]
    for r in data["ecms"]:
        a, b = r["ecms"], r["ecms_thermal"]
        lines.append(f"| {r['scenario']} | {r['cycle']} | {a['derated_s']:.0f} / {b['derated_s']:.0f} | "
                     f"{a['cutoff_s']:.0f} / {b['cutoff_s']:.0f} | {a['max_motor_temp_c']:.1f} / "
                     f"{b['max_motor_temp_c']:.1f} | {a['heat_index_max']:.2f} / {b['heat_index_max']:.2f} | "
                     f"{a['fuel_corrected_l_per_100km']:.2f} / {b['fuel_corrected_l_per_100km']:.2f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/thermal")
    ap.add_argument("--skip-dp", action="store_true")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    data = {"paper_figures": paper_figures(out)}
    data["ecms"] = ecms_table()
    data["dp"] = {} if args.skip_dp else dp_ranges(out)
    data["wall_s"] = time.perf_counter() - t0
    (out / "thermal_scenarios.json").write_text(json.dumps(data, indent=2) + "\n")
    (out / "thermal_scenarios.md").write_text(markdown(data))
    print(markdown(data))
    print(f"wrote {out} ({data['wall_s']:.0f} s)")


if __name__ == "__main__":
    main()
