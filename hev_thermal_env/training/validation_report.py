"""The final report of a run: ``best_model.zip`` and ``model.zip`` on ``eval.final_cycles`` (e.g. every
``validation_bus`` cycle, where training scored its checkpoints on a few) in every evaluation scenario, scored
by the run's selection rule (:mod:`.selection`): ``DIR/validation.csv`` (one row per model × cycle × scenario)
and the ``result.validation`` section of ``DIR/config.yaml``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.agents.policy_files import load_policy

from .artifacts import write_csv
from .evaluator import PolicyEvaluator
from .selection import run_key

VALIDATION_COLUMNS = ("model", "cycle", "scenario", "fuel_corrected_l_per_100km", "reference_l_per_100km",
                      "fuel_ratio", "delta_soc", "cutoff_s", "trace_miss_max_mps", "return_g")
MODELS = ("best_model.zip", "model.zip")


def final_validation(run: Any) -> dict[str, Any]:
    """Score the run's (a :class:`~hev_thermal_env.training.loop.TrainingRun`) best and final models on
    ``eval.final_cycles``; writes ``validation.csv``, returns the summary."""
    cfg, ev = run.config, run.config["eval"]
    evaluator = PolicyEvaluator(cfg["env"], ev["final_cycles"], ev["scenarios"], seed=int(cfg["seed"]))
    ref = run.references(evaluator.cycle_names)
    rows: list[list[Any]] = []
    models: dict[str, Any] = {}
    described: dict[str, str] = {}
    for name in MODELS:
        if not (run.out / name).is_file():
            continue
        results = evaluator.run(load_policy(run.out / name).act)
        score = run.scorer.score(results, ref)
        for r, ratio in zip(results, score.ratios):
            r = {**r, "model": name, "reference_l_per_100km": ref[run_key(r["cycle"], r["scenario"])],
                 "fuel_ratio": ratio}
            rows.append([r[k] for k in VALIDATION_COLUMNS])
        described[name] = score.describe(run.scorer.short)
        models[name] = {"score": round(score.value, 6), "qualified": score.qualified, "violations": score.violations,
                        "mean_fuel_ratio": round(float(np.mean(score.ratios)), 6),
                        "max_abs_delta_soc": round(max(abs(r["delta_soc"]) for r in results), 6),
                        "mean_fuel_corrected_l_per_100km":
                            round(float(np.mean([r["fuel_corrected_l_per_100km"] for r in results])), 4)}
    write_csv(run.out / "validation.csv", VALIDATION_COLUMNS, rows)
    summary = {"selection": run.scorer.name, "rule": run.scorer.label, "cycles": list(ev["final_cycles"]),
               "runs": len(evaluator.cycle_names) * len(ev["scenarios"]), "scenarios": list(ev["scenarios"]),
               "models": models}
    cfg["result"]["validation"] = summary
    if run.verbose:
        parts = "; ".join(f"{name}: {text}, max |dSOC| {models[name]['max_abs_delta_soc']:.3f}"
                          for name, text in described.items())
        run.log(f"validation on {summary['runs']} runs ({', '.join(summary['cycles'])} × "
                f"{', '.join(summary['scenarios'])}): {parts}")
    return summary
