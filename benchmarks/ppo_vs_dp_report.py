"""The report of ``ppo_vs_dp.py``: per-policy metrics, the seed family's IQM and CI, targets, markdown and figure.

Metrics of one policy (a seed, a shipped policy or a baseline), from its runs in every cell:

* ``ratio:CYCLE``: frontier ratio on a built-in cycle (``paper``);
* ``validation_mean`` / ``validation_worst``: mean and largest frontier ratio over the validation
  cycles (undefined if one ratio is, i.e. a final SOC outside the frontier); ``validation_mean_unselected``:
  the mean over the validation cycles no checkpoint selection looked at (the training configs'
  ``eval.cycles``, :func:`selection_cycles`);
* ``abs_dsoc_max``: largest |ΔSOC| over every ``paper`` cell; ``abs_dsoc_max_long``: over cycles of
  3,000 s or more;
* ``thermal_cutoff_s``: cutoff seconds in the ``hot``/``summer`` cells where the optimum has none;
  ``thermal_derated_excess_s``: derated seconds beyond the optimum's, summed over those cells (no target).

The family's value of a metric is the IQM over its seeds with a 95 % bootstrap interval; a seed whose
value is undefined is left out and counted. A target is met when the value (the family's IQM) is at
most the limit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.stats import iqm, iqm_ci

TARGETS = {"ratio:hwfet": 1.015, "ratio:beijing": 1.03, "ratio:udds": 1.04, "ratio:us06": 1.04,
           "ratio:wltc_3b": 1.04, "validation_mean": 1.03, "validation_worst": 1.06, "validation_mean_unselected": None,
           "abs_dsoc_max": 0.02, "abs_dsoc_max_long": 0.02, "thermal_cutoff_s": 0.0, "thermal_derated_excess_s": None}
TEXT = {"validation_mean": "validation cycles: mean ratio", "validation_worst": "validation cycles: worst ratio",
        "validation_mean_unselected": "validation cycles never selected on: mean ratio",
        "abs_dsoc_max": "largest abs(ΔSOC), every paper cycle",
        "abs_dsoc_max_long": "largest abs(ΔSOC), cycles ≥ 3,000 s",
        "thermal_cutoff_s": "hot/summer: cutoff s where the optimum has none",
        "thermal_derated_excess_s": "hot/summer: derated s beyond the optimum's"}
SOC_LIMIT = 0.02
LONG_S = 3000


def selection_note(data: dict[str, Any]) -> str:
    """The notes' line on the cycles ``best_model.zip`` was chosen on and which cells they overlap."""
    selected = selection_cycles(data)
    shown = ", ".join(f"`{c}`" for c in selected)
    overlap = [c["cycle"] for c in data["cells"] if _validation(c) and c["cycle"] in selected]
    if not overlap:
        return (f"* Training chose `best_model.zip` on {shown} (`paper`, `full_bus`); none of them is a cell here, so "
                "every validation row is on cycles never selected on.")
    return (f"* Training chose `best_model.zip` on {shown}; of these, {', '.join(f'`{c}`' for c in overlap)} are cells "
            "here, and the row of validation cycles never selected on leaves them out.")


def selection_cycles(data: dict[str, Any]) -> list[str]:
    """The cycles any seed's training chose its ``best_model.zip`` on (its config's ``eval.cycles``), in order."""
    return list(dict.fromkeys(c for r in data.get("training") or [] for c in r["selection_cycles"]))


def _paper(cell: dict) -> bool:
    return cell["scenario"] == "paper"


def _validation(cell: dict) -> bool:
    return _paper(cell) and cell["family"] != "built-in"


def _all_defined(values: list) -> bool:
    return bool(values) and all(v is not None for v in values)


def member_metrics(cells: list[dict], name: str, selected: list[str] = ()) -> dict[str, float | None]:
    """Every metric of the policy ``name`` (None when undefined; absent when its cells did not run).

    ``selected``: the cycles checkpoints were selected on (left out of ``validation_mean_unselected``).
    """
    m: dict[str, float | None] = {}
    for c in cells:
        if _paper(c) and c["family"] == "built-in" and f"ratio:{c['cycle']}" in TARGETS:
            m[f"ratio:{c['cycle']}"] = c["runs"][name]["frontier_ratio"]
    val = [c["runs"][name]["frontier_ratio"] for c in cells if _validation(c)]
    if val:
        m["validation_mean"] = float(np.mean(val)) if _all_defined(val) else None
        m["validation_worst"] = float(np.max(val)) if _all_defined(val) else None
    rest = [c["runs"][name]["frontier_ratio"] for c in cells if _validation(c) and c["cycle"] not in selected]
    if rest:
        m["validation_mean_unselected"] = float(np.mean(rest)) if _all_defined(rest) else None
    paper = [c for c in cells if _paper(c)]
    if paper:
        m["abs_dsoc_max"] = max(abs(c["runs"][name]["delta_soc"]) for c in paper)
    long = [c for c in paper if c["duration_s"] >= LONG_S]
    if long:
        m["abs_dsoc_max_long"] = max(abs(c["runs"][name]["delta_soc"]) for c in long)
    thermal = [c for c in cells if not _paper(c)]
    if thermal:
        avoided = [c for c in thermal if c["optimum"]["cutoff_s"] == 0]
        m["thermal_cutoff_s"] = float(sum(c["runs"][name]["cutoff_s"] for c in avoided))
        m["thermal_derated_excess_s"] = float(sum(max(0.0, c["runs"][name]["derated_s"] - c["optimum"]["derated_s"])
                                                  for c in thermal))
    return m


def met(value: float | None, limit: float | None) -> bool | None:
    """Whether ``value`` meets ``limit`` (None without a limit; an undefined value does not)."""
    if limit is None:
        return None
    return value is not None and value <= limit + 1e-12


def family_stat(values: list[float | None]) -> dict[str, Any]:
    """IQM and 95 % bootstrap interval of the defined ``values``; how many were left out."""
    ok = [float(v) for v in values if v is not None and np.isfinite(v)]
    lo, hi = iqm_ci(ok) if ok else (None, None)
    return {"values": values, "iqm": iqm(ok) if ok else None, "ci": [lo, hi], "n": len(ok),
            "left_out": len(values) - len(ok)}


def summarize(data: dict[str, Any]) -> dict[str, Any]:
    """Metrics of every policy and baseline, the family's IQM [CI] per metric and per cell, verdicts."""
    cells, seeds = data["cells"], data["seeds"]
    names = [*seeds, *data["policies"], *data["baselines"]]
    selected = selection_cycles(data)
    members = {n: member_metrics(cells, n, selected) for n in names}
    keys = [k for k in TARGETS if k in members[names[0]]]
    verdicts = {n: {k: met(members[n][k], TARGETS[k]) for k in keys} for n in names}
    family = {}
    if seeds:
        for k in keys:
            stat = family_stat([members[s][k] for s in seeds])
            family[k] = {**stat, "target": TARGETS[k], "met": met(stat["iqm"], TARGETS[k])}
    per_cell = {}
    if seeds:
        for c in cells:
            per_cell[f"{c['cycle']}/{c['scenario']}"] = {
                "ratio": family_stat([c["runs"][s]["frontier_ratio"] for s in seeds]),
                "derated_s": family_stat([c["runs"][s]["derated_s"] for s in seeds]),
                "cutoff_s": family_stat([c["runs"][s]["cutoff_s"] for s in seeds])}
    return {"metrics": members, "verdicts": verdicts, "family": family, "family_per_cell": per_cell, "keys": keys}


def _r(x: float | None, digits: int = 4) -> str:
    return "undef." if x is None else f"{x:.{digits}f}"


def _mark(ok: bool | None) -> str:
    return "" if ok is None else (" ✓" if ok else " ✗")


def _iqm_text(stat: dict[str, Any], digits: int = 4) -> str:
    lo, hi = stat["ci"]
    ci = f" [{_r(lo, digits)}, {_r(hi, digits)}]" if lo is not None else ""
    out = f" ({stat['left_out']} undef.)" if stat["left_out"] else ""
    return f"{_r(stat['iqm'], digits)}{ci}{out}"


def _metric_text(key: str) -> str:
    return f"`{key.split(':', 1)[1]}` frontier ratio" if key.startswith("ratio:") else TEXT[key]


def targets_table(data: dict[str, Any]) -> list[str]:
    """The must-show table: each metric, its limit, the family, every seed, policy and baseline, met or not."""
    s = data["summary"]
    seeds, others = data["seeds"], [*data["policies"], *data["baselines"]]
    head = ["metric", "target", f"family IQM [95 % CI] ({len(seeds)} seeds)", "family", *seeds, *others]
    lines = ["| " + " | ".join(head) + " |", "|---|---:|---:|---|" + "---:|" * (len(seeds) + len(others))]
    for k in s["keys"]:
        digits = 0 if k.startswith("thermal") else 4
        fam = s["family"].get(k)
        limit = "—" if TARGETS[k] is None else (f"≤ {TARGETS[k]:g}" if TARGETS[k] else "0")
        cells = [_metric_text(k), limit,
                 _iqm_text(fam, digits) if fam else "—",
                 "—" if not fam or fam["met"] is None else ("met" if fam["met"] else "**not met**")]
        cells += [_r(s["metrics"][n][k], digits) + _mark(s["verdicts"][n][k]) for n in [*seeds, *others]]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def ratio_table(data: dict[str, Any]) -> list[str]:
    """Per cell: the optimum, every seed's ratio, the family IQM [CI], policies, baselines and the target."""
    s, seeds, others = data["summary"], data["seeds"], [*data["policies"], *data["baselines"]]
    head = ["cycle / scenario", "s", "kind", "optimum g (final SOC)", *seeds, "family IQM [CI]", *others, "target"]
    lines = ["| " + " | ".join(head) + " |", "|---|---:|---|---:|" + "---:|" * (len(seeds) + len(others) + 2)]
    for c in data["cells"]:
        key = f"ratio:{c['cycle']}"
        limit = TARGETS.get(key) if _paper(c) else None
        limit = TARGETS["validation_worst"] if _validation(c) else limit
        target = "—" if limit is None else ("worst " if _validation(c) else "") + f"≤ {limit:g}"
        fam = s["family_per_cell"].get(f"{c['cycle']}/{c['scenario']}")
        row = [f"{c['cycle']} / {c['scenario']}", f"{c['duration_s']}", c["family"],
               f"{c['optimum']['cost_g']:.1f} ({c['optimum']['soc_final']:.3f})"]
        row += [_r(c["runs"][n]["frontier_ratio"]) + _mark(met(c["runs"][n]["frontier_ratio"], limit)) for n in seeds]
        row.append((_iqm_text(fam["ratio"]) + _mark(met(fam["ratio"]["iqm"], limit))) if fam else "—")
        row += [_r(c["runs"][n]["frontier_ratio"]) + _mark(met(c["runs"][n]["frontier_ratio"], limit)) for n in others]
        lines.append("| " + " | ".join(row + [target]) + " |")
    return lines


def soc_table(data: dict[str, Any]) -> list[str]:
    """ΔSOC of every run in the ``paper`` cells (✗ beyond ± 0.02)."""
    names = [*data["seeds"], *data["policies"], *data["baselines"]]
    lines = ["| cycle | s | optimum | " + " | ".join(names) + " |", "|---|---:|---:|" + "---:|" * len(names)]
    for c in data["cells"]:
        if not _paper(c):
            continue
        row = [c["cycle"], f"{c['duration_s']}", f"{c['optimum']['delta_soc']:+.4f}"]
        row += [f"{c['runs'][n]['delta_soc']:+.4f}" + _mark(abs(c["runs"][n]["delta_soc"]) <= SOC_LIMIT) for n in names]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def thermal_table(data: dict[str, Any]) -> list[str]:
    """Cutoff / derated seconds in ``hot`` and ``summer`` next to the optimum's."""
    names = [*data["seeds"], *data["policies"], *data["baselines"]]
    per_cell = data["summary"]["family_per_cell"]
    lines = ["| cycle / scenario | optimum | " + " | ".join(names) + " | family IQM derated s |",
             "|---|---:|" + "---:|" * (len(names) + 1)]
    for c in data["cells"]:
        if _paper(c):
            continue
        o = c["optimum"]
        row = [f"{c['cycle']} / {c['scenario']}", f"{o['cutoff_s']:.0f} / {o['derated_s']:.0f}"]
        for n in names:
            r = c["runs"][n]
            bad = o["cutoff_s"] == 0 and r["cutoff_s"] > 0
            row.append(f"{r['cutoff_s']:.0f} / {r['derated_s']:.0f}" + (" ✗" if bad else ""))
        fam = per_cell.get(f"{c['cycle']}/{c['scenario']}")
        row.append(_iqm_text(fam["derated_s"], 0) if fam else "—")
        lines.append("| " + " | ".join(row) + " |")
    return lines


def training_table(data: dict[str, Any]) -> list[str]:
    lines = ["| seed | env-steps | training wall s | env-steps/s | env share | train.py process s | "
             "validation fuel / ECMS (best, final) | command |", "|---|---:|---:|---:|---:|---:|---:|---|"]
    for t in data["training"]:
        v = t["validation_vs_ecms"] or {}
        share = "—" if t["env_share"] is None else f"{100 * t['env_share']:.1f} %"
        proc = "reused" if t["process_wall_s"] is None else f"{t['process_wall_s']:.0f}"
        lines.append(f"| {t['seed']} | {t['timesteps']} | {_r(t['wall_s'], 0)} | {_r(t['steps_per_s'], 0)} | {share} | "
                     f"{proc} | {_r(v.get('best_model.zip'))}, {_r(v.get('model.zip'))} | `{t['command']}` |")
    return lines


def optimum_table(data: dict[str, Any]) -> list[str]:
    lines = ["| cycle / scenario | s | solve s | wall s (optimum) | wall s (all runs) | max states | cost g | grid |",
             "|---|---:|---:|---:|---:|---:|---:|---|"]
    for c in data["cells"]:
        o = c["optimum"]
        lines.append(f"| {c['cycle']} / {c['scenario']} | {c['duration_s']} | {_r(o['solve_s'], 1)} | "
                     f"{o['optimum_wall_s']:.1f} | {c['runs_wall_s']:.1f} | {o['max_states']} | {o['cost_g']:.1f} | "
                     f"{o['grid']} |")
    return lines


def markdown(data: dict[str, Any]) -> str:
    """The whole report."""
    n = len(data["seeds"])
    warned = [f"* `{k}`: {v}" for k, v in data["policy_warnings"].items() if v]
    lines = [
        "# Learned policies against the thermal optimum's frontier", "",
        f"Ratio = the run's yardstick cost (g) / the cost of the thermal optimum (`{data['reference']}`, solved once "
        "per cycle × scenario) at the run's own final SOC: 1 is the optimum, no battery price involved; undefined "
        "(undef.) when the final SOC lies outside the frontier. "
        f"Seed family: {n} PPO seeds, `{data['model']}` of `RUNS/seed_S`, default hyperparameters "
        "(`agents/hyperparams/ppo.yaml`: trained on generated cycle families, never on `hwfet`, `beijing` or a "
        "validation cycle); IQM over the seeds with a 95 % bootstrap interval (`hev_thermal_env.stats`). "
        f"Shipped policy: `ppo` (`agents/policies/ppo_default`). Command: `{data['command']}` "
        f"(commit {str(data['commit'])[:10]}).", "",
        "## targets", "", *targets_table(data), "",
        "✓/✗: the value against the target; the family's verdict is its IQM's.", "",
        "## frontier ratio per cycle and scenario", "", *ratio_table(data), "",
        "## ΔSOC (paper)", "", *soc_table(data), "",
        "## hot and summer: cutoff s / derated s", "", *thermal_table(data), "",
        "✗: a cutoff where the optimum has none.", "",
        "## training (each run's config.yaml `result`)", "", *training_table(data), "",
        "Training wall s: the training loop (`result.wall_s`); train.py process s: the whole command as this "
        "benchmark timed it, the final validation on every validation cycle included.", "",
        "## the optimum per cell", "", *optimum_table(data), "",
        "## notes", "",
        selection_note(data),
        *warned,
        f"* Machine: {data['machine']}; cells evaluated in {data['eval_wall_s']:.0f} s, training "
        f"{data['training_wall_s']:.0f} s.", ""]
    return "\n".join(lines)


def plot(data: dict[str, Any], path: Path) -> None:
    """Frontier ratio and ΔSOC per cell: seeds (dots), family IQM with its interval, policies, baselines, targets."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hev_thermal_env.io import save_png

    cells, seeds = data["cells"], data["seeds"]
    x = np.arange(len(cells))
    labels = [c["cycle"].replace("validation_bus:", "val ") + ("" if _paper(c) else f"\n{c['scenario']}")
              for c in cells]
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(max(8.0, 0.55 * len(cells) + 3), 7.5), sharex=True)
    top = 1.12
    others = [*data["policies"], *data["baselines"]]
    markers = dict(zip(others, "DsvP^<>*"))
    for k, c in enumerate(cells):
        r = [min(c["runs"][s]["frontier_ratio"], top) for s in seeds if c["runs"][s]["frontier_ratio"] is not None]
        ax.scatter([k] * len(r), r, s=12, color="0.55", zorder=2, label="seeds" if k == 0 else None)
        bx.scatter([k] * len(seeds), [c["runs"][s]["delta_soc"] for s in seeds], s=12, color="0.55", zorder=2)
        fam = data["summary"]["family_per_cell"].get(f"{c['cycle']}/{c['scenario']}")
        if fam and fam["ratio"]["iqm"] is not None:
            lo, hi = fam["ratio"]["ci"]
            err = None if lo is None else [[fam["ratio"]["iqm"] - lo], [hi - fam["ratio"]["iqm"]]]
            ax.errorbar([k], [min(fam["ratio"]["iqm"], top)], yerr=err, fmt="o", color="k", ms=5, capsize=3,
                        zorder=4, label="family IQM, 95 % CI" if k == 0 else None)
        limit = TARGETS.get(f"ratio:{c['cycle']}") if _paper(c) else None
        limit = TARGETS["validation_worst"] if _validation(c) else limit
        if limit is not None:
            ax.hlines(limit, k - 0.4, k + 0.4, color="tab:red", lw=1.5, label="target" if k == 0 else None)
    for i, n in enumerate(others):
        r = np.array([np.nan if c["runs"][n]["frontier_ratio"] is None else c["runs"][n]["frontier_ratio"]
                      for c in cells])
        dx = 0.12 + 0.06 * i
        ax.scatter(x + dx, np.minimum(r, top), marker=markers.get(n, "x"), s=22, color=f"C{i}", label=n, zorder=3)
        bx.scatter(x + dx, [c["runs"][n]["delta_soc"] for c in cells], marker=markers.get(n, "x"), s=22,
                   color=f"C{i}", zorder=3)
    drawn = [r["frontier_ratio"] for c in cells for r in c["runs"].values() if r["frontier_ratio"] is not None]
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_ylim(min([0.995, *[v - 0.003 for v in drawn]]), top + 0.005)
    ax.set_ylabel(f"cost / optimum's frontier\n(clipped at {top}; undefined not drawn)")
    ax.set_title("Learned policies against the thermal optimum (1 = optimum at the run's own final SOC)", fontsize=10)
    ax.legend(fontsize=7, ncol=4, loc="upper left")
    bx.axhspan(-SOC_LIMIT, SOC_LIMIT, color="tab:green", alpha=0.12, label=f"|ΔSOC| ≤ {SOC_LIMIT}")
    bx.set_ylabel("ΔSOC")
    bx.legend(fontsize=7, loc="upper left")
    bx.set_xticks(x, labels, rotation=60, fontsize=7)
    for a in (ax, bx):
        a.grid(alpha=0.3)
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)
