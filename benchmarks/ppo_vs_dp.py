#!/usr/bin/env python
"""PPO against the DP optimum: corrected fuel of PPO policies trained with several seeds.

For every seed, ``train.py`` trains a PPO policy with the default hyperparameters
(``agents/hyperparams/ppo.yaml``: cycles ``hwfet`` + ``random_bus``, scenario ``random``) into
``RUNS/seed_S`` (skipped with ``--reuse`` when the run has finished). Then every final policy
(``model.zip``, not the best-on-evaluation one, so no selection on the reported cycles), the shipped
default policy and the classic strategies drive:

* ``paper`` scenario: ``hwfet`` (trained on), ``beijing`` (synthetic; from the same generator
  as ``random_bus`` but never trained on), ``udds``, ``wltc_3b`` and ``us06`` (never seen; ``us06``
  is the second evaluation cycle watched during training). ``wltc_3b`` and ``us06`` exceed the bus's
  top speed (89 km/h), so every strategy carries a trace miss there (priced in the corrected fuel).
* ``hot`` scenario on ``hwfet`` and ``beijing``: cutoff seconds of PPO against ``ecms``
  (thermal-blind) and ``ecms_thermal``.

Writes ``OUT/ppo_vs_dp.json`` (every run's summary, training wall times and settings),
``OUT/ppo_vs_dp.md`` (the tables, with the targets) and ``OUT/ppo_vs_dp.png`` (evaluation
during training, all seeds)::

    python benchmarks/ppo_vs_dp.py --seeds 0 1 2 --runs runs/ppo_vs_dp --out benchmarks/results
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PAPER_CYCLES = ("hwfet", "beijing", "udds", "wltc_3b", "us06")
HOT_CYCLES = ("hwfet", "beijing")
BASELINES = ("rule", "ecms", "ecms_thermal")
HOT_BASELINES = ("ecms", "ecms_thermal", "rule")
TRAINED_ON = {"hwfet": "yes", "beijing": "no (same generator as random_bus)", "udds": "no", "wltc_3b": "no",
              "us06": "no (watched during training)"}
TARGETS = {"hwfet": 1.03, "beijing": 1.05, "udds": 1.05, "wltc_3b": 1.05, "us06": 1.05}
SOC_TARGET = 0.02


def train_seed(seed: int, runs: Path, reuse: bool, extra: list[str]) -> dict[str, Any]:
    from hev_thermal_env.training.config import load_run_config

    out = runs / f"seed_{seed}"
    if reuse and (out / "model.zip").is_file():
        cfg = load_run_config(out)
        if (cfg.get("result") or {}).get("finished"):
            print(f"seed {seed}: reusing {out}", flush=True)
            return cfg
    if out.exists():
        import shutil

        shutil.rmtree(out)
    shown = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out  # recorded in command.txt
    cmd = [sys.executable, "train.py", "--algo", "ppo", "--seed", str(seed), "--out", str(shown), "--no-progress",
           *extra]
    print("$ " + " ".join(shlex.quote(c) for c in cmd), flush=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, check=True)
    print(f"seed {seed}: trained in {time.perf_counter() - t0:.0f} s", flush=True)
    return load_run_config(out)


def run(strategy_name: str, cycle: str, scenario: str, **options: Any) -> dict[str, Any]:
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.runner import run_strategy

    s = run_strategy(get_strategy(strategy_name, **options), cycle, scenario).summary
    keep = ("fuel_corrected_l_per_100km", "fuel_l_per_100km", "delta_soc", "soc_final", "cutoff_s", "derated_s",
            "max_motor_temp_c", "trace_miss_max_mps", "missed_wheel_energy_kwh", "wall_s")
    return {"cycle": cycle, "scenario": scenario, "strategy": strategy_name, **{k: s[k] for k in keep},
            "strategy_settings": s.get("strategy_settings")}


def fmt_ratio(x: float, target: float | None = None) -> str:
    mark = "" if target is None else (" ✓" if x <= target else " ✗")
    return f"{x:.4f}{mark}"


def markdown(data: dict[str, Any]) -> str:
    seeds = data["seeds"]
    rows = data["paper"]
    dp = {r["cycle"]: r["fuel_corrected_l_per_100km"] for r in rows if r["strategy"] == "dp"}
    by = {(r["cycle"], r["strategy"]): r for r in rows}
    ppo_names = [f"ppo:seed_{s}" for s in seeds]
    lines = ["# PPO vs DP: corrected fuel relative to the DP optimum", "",
             f"PPO: {len(seeds)} training seeds ({', '.join(map(str, seeds))}), final models, default hyperparameters "
             f"(`agents/hyperparams/ppo.yaml`); trained on `hwfet` + `random_bus`, scenario `random`. "
             f"Corrected fuel = fuel + battery energy used + missed wheel energy, at the stated efficiencies "
             f"(equal service). DP: `dp` (SOC state, {data['dp_settings']}).", "",
             *targets_block(data, ppo_names, dp, by), "",
             "## paper scenario", "",
             "| cycle | trained on | DP L/100 km | " + " | ".join(
                 [*BASELINES, *[f"ppo s{s}" for s in seeds], "ppo mean", "ppo (shipped)"]) + " | target |",
             "|---|---|---:|" + "---:|" * (len(BASELINES) + len(seeds) + 2) + "---:|"]
    for c in data["paper_cycles"]:
        ratios = [by[(c, n)]["fuel_corrected_l_per_100km"] / dp[c] for n in ppo_names]
        cells = [fmt_ratio(by[(c, b)]["fuel_corrected_l_per_100km"] / dp[c]) for b in BASELINES]
        cells += [fmt_ratio(x) for x in ratios]
        cells.append(fmt_ratio(float(np.mean(ratios)), TARGETS[c]))
        cells.append(fmt_ratio(by[(c, "ppo")]["fuel_corrected_l_per_100km"] / dp[c]))
        lines.append(f"| {c} | {TRAINED_ON[c]} | {dp[c]:.3f} | " + " | ".join(cells) + f" | ≤ {TARGETS[c]:.2f} |")
    lines += ["", "Ratios: corrected fuel / DP's on the same cycle (✓/✗: PPO mean against the target).", "",
              "### ΔSOC and cutoff (paper)", "",
              "| cycle | DP ΔSOC | " + " | ".join([*BASELINES, *[f"ppo s{s}" for s in seeds], "ppo (shipped)"])
              + " ΔSOC | PPO cutoff s (all seeds) | max trace miss m/s (DP / PPO) |",
              "|---|---:|" + "---:|" * (len(BASELINES) + len(seeds) + 1) + "---:|---:|"]
    for c in data["paper_cycles"]:
        names = [*BASELINES, *ppo_names, "ppo"]
        cells = []
        for n in names:
            d = by[(c, n)]["delta_soc"]
            cells.append(f"{d:+.4f}" + ("" if not n.startswith("ppo") else (" ✓" if abs(d) <= SOC_TARGET else " ✗")))
        cut = sum(by[(c, n)]["cutoff_s"] for n in [*ppo_names, "ppo"])
        miss = max(by[(c, n)]["trace_miss_max_mps"] for n in [*ppo_names, "ppo"])
        lines.append(f"| {c} | {by[(c, 'dp')]['delta_soc']:+.4f} | " + " | ".join(cells)
                     + f" | {cut:.0f} | {by[(c, 'dp')]['trace_miss_max_mps']:.2f} / {miss:.2f} |")
    hot = {(r["cycle"], r["strategy"]): r for r in data["hot"]}
    hot_names = [*HOT_BASELINES, *ppo_names, "ppo"]
    lines += ["", "## hot scenario: motor cutoff (s) and corrected fuel", "",
              "40 °C ambient, motor starting at 50 °C, cooling degraded (`hot`).", "",
              "| cycle | " + " | ".join(n.replace("ppo:seed_", "ppo s") if n != "ppo" else "ppo (shipped)"
                                      for n in hot_names) + " |",
              "|---|" + "---:|" * len(hot_names)]
    for c in data["hot_cycles"]:
        cells = [f"{hot[(c, n)]['cutoff_s']:.0f} s / {hot[(c, n)]['fuel_corrected_l_per_100km']:.2f}"
                 for n in hot_names]
        lines.append(f"| {c} | " + " | ".join(cells) + " |")
    lines += ["", "Cells: cutoff seconds / corrected fuel L/100 km.", "", "## training", "",
              "| seed | timesteps | wall s | env-steps/s | env step share | command |", "|---|---:|---:|---:|---:|---|"]
    for t in data["training"]:
        lines.append(f"| {t['seed']} | {t['timesteps']} | {t['wall_s']:.0f} | {t['steps_per_s']:.0f} | "
                     f"{100 * t['env_share']:.1f} % | `{t['command']}` |")
    lines += ["", "## notes", "",
              "* `wltc_3b` and `us06` run faster than the bus's top speed (89 km/h): every strategy misses part "
              "of the trace there (max speed deficit above); the miss is priced in the corrected fuel. On these two "
              "the policies end with the battery lower than DP, which plans the whole cycle (the policy sees 10 s "
              "ahead).",
              "* The gap on `beijing` is electric drive: DP and ECMS drive the launches on the motor alone (u = 1, "
              "engine off) for about a third of the driving seconds; the PPO policies never choose u = 1 and keep "
              "the engine on (a share just below 1 is among the worst choices, so the Gaussian policy does not "
              "find the switch).",
              "* ECMS evaluates 41 candidate splits per step on the physics (`env.peek`); PPO sees only the "
              "observation.",
              "* The evaluation during training (`ppo_vs_dp.png`, `runs/.../evaluations.csv`) watches `beijing` "
              "and `us06`; the rows above use the final models."]
    lines += ["", f"Machine: {data['machine']}. Env step share: time inside the batched env's reset/step over the "
              "training loop (evaluation excluded).", ""]
    return "\n".join(lines)


def targets_block(data: dict[str, Any], ppo_names: list[str], dp: dict[str, float], by: dict) -> list[str]:
    """The targets and whether the PPO seeds meet them, in a few lines."""
    lines = ["## targets", ""]
    for c in data["paper_cycles"]:
        ratios = [by[(c, n)]["fuel_corrected_l_per_100km"] / dp[c] for n in ppo_names]
        socs = [by[(c, n)]["delta_soc"] for n in ppo_names]
        ok_soc = sum(abs(x) <= SOC_TARGET for x in socs)
        lines.append(f"* {c}: corrected fuel {min(ratios):.3f}-{max(ratios):.3f} × DP (mean {np.mean(ratios):.3f}; "
                     f"target ≤ {TARGETS[c]:.2f}: {'met' if max(ratios) <= TARGETS[c] else 'missed'}); "
                     f"|ΔSOC| ≤ {SOC_TARGET} for {ok_soc} of {len(socs)} seeds (worst {max(socs, key=abs):+.4f})")
    cut = sum(r["cutoff_s"] for r in data["paper"] if r["strategy"].startswith("ppo"))
    lines.append(f"* cutoff in `paper`: {cut:.0f} s over all PPO runs (target 0)")
    hot = [r for r in data["hot"] if r["strategy"] in ppo_names]
    ecms = {r["cycle"]: r["cutoff_s"] for r in data["hot"] if r["strategy"] == "ecms"}
    lines.append("* `hot`: PPO cutoff " + ", ".join(
        f"{c} {sum(r['cutoff_s'] for r in hot if r['cycle'] == c):.0f} s (ecms {ecms[c]:.0f} s)"
        for c in data["hot_cycles"]) + " summed over the seeds")
    t = data["training"]
    lines.append(f"* training wall time {min(x['wall_s'] for x in t):.0f}-{max(x['wall_s'] for x in t):.0f} s per seed "
                 f"(target ≤ 900 s on 2 cores)")
    return lines


def plot_curves(runs: dict[int, Path], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hev_thermal_env.io import save_png
    from hev_thermal_env.training.artifacts import read_evaluations
    from hev_thermal_env.training.config import load_run_config

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for seed, d in runs.items():
        rows = read_evaluations(d / "evaluations.csv")
        ref = (load_run_config(d).get("result") or {}).get("dp_reference_l_per_100km") or {}
        for ax, cycle in zip(axes, ("beijing", "us06")):
            pts = sorted({r["timesteps"]: r for r in rows if r["cycle"] == cycle and r["scenario"] == "paper"}.items())
            if pts:
                ax.plot([p[0] for p in pts], [p[1]["fuel_corrected_l_per_100km"] for p in pts], marker=".",
                        label=f"seed {seed}")
            if seed == min(runs) and f"{cycle} / paper" in ref:
                ax.axhline(ref[f"{cycle} / paper"], color="k", ls="--", lw=1, label="DP")
    for ax, cycle in zip(axes, ("beijing", "us06")):
        ax.set_title(f"{cycle} (paper), deterministic evaluation during training", fontsize=9)
        ax.set_xlabel("timesteps")
        ax.set_ylabel("corrected fuel (L/100 km)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--runs", default="runs/ppo_vs_dp", help="directory of the training runs (seed_S)")
    p.add_argument("--reuse", action="store_true", help="reuse finished runs instead of training again")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    p.add_argument("--train-args", default="", help="extra train.py arguments, quoted (e.g. \"--timesteps 100000\")")
    args = p.parse_args(argv)

    import platform

    import torch

    from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR
    from hev_thermal_env.io import atomic_write_json, atomic_write_text

    torch.set_num_threads(1)
    runs = Path(args.runs) if Path(args.runs).is_absolute() else ROOT / args.runs
    extra = shlex.split(args.train_args)
    configs = {s: train_seed(s, runs, args.reuse, extra) for s in args.seeds}
    training = []
    for s, cfg in configs.items():
        res = cfg["result"]
        training.append({"seed": s, "timesteps": res["timesteps_done"], "wall_s": res["wall_s"],
                         "steps_per_s": res["steps_per_s"], "env_share": res["env_share"],
                         "command": " ".join((runs / f"seed_{s}" / "command.txt").read_text().split())})
    ppo_models = {f"ppo:seed_{s}": str(runs / f"seed_{s}" / "model.zip") for s in args.seeds}
    paper, hot = [], []
    t0 = time.perf_counter()
    for c in PAPER_CYCLES:
        paper.append(run("dp", c, "paper", on_infeasible="closest"))
        for b in BASELINES:
            paper.append(run(b, c, "paper"))
        for name, path in ppo_models.items():
            paper.append({**run(f"ppo:{path}", c, "paper"), "strategy": name})
        paper.append(run("ppo", c, "paper"))
        print(f"paper {c}: done", flush=True)
    for c in HOT_CYCLES:
        for b in HOT_BASELINES:
            hot.append(run(b, c, "hot"))
        for name, path in ppo_models.items():
            hot.append({**run(f"ppo:{path}", c, "hot"), "strategy": name})
        hot.append(run("ppo", c, "hot"))
    dp_settings = next(r["strategy_settings"] for r in paper if r["strategy"] == "dp")
    grid = dp_settings.get("grid") if isinstance(dp_settings, dict) else None
    data = {
        "seeds": args.seeds, "paper_cycles": list(PAPER_CYCLES), "hot_cycles": list(HOT_CYCLES),
        "targets": {"corrected_fuel_vs_dp": TARGETS, "abs_delta_soc": SOC_TARGET, "cutoff_s_paper": 0},
        "shipped_policy": str(DEFAULT_POLICY_DIR.relative_to(ROOT) if DEFAULT_POLICY_DIR.is_relative_to(ROOT)
                              else DEFAULT_POLICY_DIR),
        "dp_settings": f"grid {grid}, n_u {dp_settings.get('n_u')}, on_infeasible closest" if grid else "defaults",
        "training": training, "paper": paper, "hot": hot, "eval_wall_s": round(time.perf_counter() - t0, 1),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, torch threads 1",
    }
    data = json.loads(json.dumps(data).replace(str(ROOT) + "/", ""))  # paths relative to the repository
    out = Path(args.out)
    atomic_write_json(out / "ppo_vs_dp.json", data)
    md = markdown(data)
    atomic_write_text(out / "ppo_vs_dp.md", md)
    plot_curves({s: runs / f"seed_{s}" for s in args.seeds}, out / "ppo_vs_dp.png")
    print(md)
    print(json.dumps({"written": [str(out / f) for f in ("ppo_vs_dp.json", "ppo_vs_dp.md", "ppo_vs_dp.png")]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
