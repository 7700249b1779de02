"""Choosing ``best_model.zip``: by corrected fuel relative to a reference, never a checkpoint that drifts the SOC.

The training loop's own ``evaluate`` runs on fabricated evaluation results (no model is trained here)."""

from __future__ import annotations

import numpy as np
import pytest

import hev_thermal_env.training.loop as loop
from hev_thermal_env.training.artifacts import read_evaluations
from hev_thermal_env.training.config import build_config
from hev_thermal_env.training.curves import selected_step
from hev_thermal_env.training.selection import (
    SCORERS,
    SOC_LIMIT,
    Score,
    Scorer,
    compute_references,
    fuel_ratio_score,
    get_scorer,
    run_key,
)

CYCLES = ("validation_bus:0", "validation_bus:1")
REFERENCE = {run_key(c, "paper"): 40.0 for c in CYCLES}


def results(ret: float, ratio: float, dsoc: float = 0.0) -> list[dict]:
    """One fabricated evaluation: every run with this return and fuel ratio, the last with ``dsoc``."""
    return [{"cycle": c, "scenario": "paper", "return_g": ret, "fuel_corrected_l_per_100km": 40.0 * ratio,
             "delta_soc": dsoc if i == len(CYCLES) - 1 else 0.001, "cutoff_s": 0.0, "trace_miss_max_mps": 0.0}
            for i, c in enumerate(CYCLES)]


class FakeEvaluator:
    def __init__(self, evaluations):
        self.evaluations = list(evaluations)
        self.cycle_names = list(CYCLES)

    def run(self, act):
        return self.evaluations.pop(0)


class FakeModel:
    num_timesteps = 0

    def get_env(self):
        return None


def run_selection(tmp_path, monkeypatch, evaluations, selection="fuel_vs_ecms") -> tuple[list[int], object]:
    """Feed ``evaluations`` (one per 1000 env-steps) through ``TrainingRun.evaluate``; returns the steps saved as
    ``best_model.zip`` and the run."""
    saved: list[int] = []
    model = FakeModel()
    monkeypatch.setattr(loop, "LoadedPolicy", lambda model, stats: type("P", (), {"act": None})())
    monkeypatch.setattr(loop, "save_model_and_stats", lambda m, stats, path, spath: saved.append(m.num_timesteps))
    config = build_config("ppo", cycles=["random_bus"], eval_cycles=list(CYCLES), eval_scenarios=["paper"],
                          overrides={"eval.selection": selection})
    config["result"] = {"selection_reference": dict(REFERENCE)}
    run = loop.TrainingRun(config, tmp_path, verbose=0)
    run.evaluator = FakeEvaluator(evaluations)
    for k in range(len(evaluations)):
        model.num_timesteps = 1000 * (k + 1)
        run.evaluate(model)
    return saved, run


def test_best_model_is_the_best_fuel_not_the_best_return(tmp_path, monkeypatch):
    evaluations = [results(-100.0, 1.05), results(-50.0, 1.10), results(-80.0, 1.02), results(-90.0, 1.04)]
    saved, run = run_selection(tmp_path, monkeypatch, evaluations)
    assert saved == [1000, 3000]  # step 2000 has the best return but the worst fuel
    rows = read_evaluations(tmp_path / "evaluations.csv")
    assert selected_step(rows) == 3000
    assert [r["timesteps"] for r in rows if r["best"]] == [1000, 1000, 3000, 3000]
    assert rows[4]["fuel_ratio"] == pytest.approx(1.02) and rows[4]["score"] == pytest.approx(1.02)
    run.record_session({"timesteps_done": 4000, "session_wall_s": 1.0, "env_share": None, "steps_per_s": None},
                       finished=True)
    assert run.config["result"]["best_eval"]["timesteps"] == 3000
    # the same evaluations under the return rule choose step 2000: the rule, not the data, decides
    saved_by_return, _ = run_selection(tmp_path / "by_return", monkeypatch, evaluations, selection="mean_return")
    assert saved_by_return == [1000, 2000]


def test_a_checkpoint_that_drifts_the_soc_is_not_chosen(tmp_path, monkeypatch):
    evaluations = [results(-100.0, 1.05), results(-60.0, 0.90, dsoc=SOC_LIMIT + 0.005), results(-90.0, 1.07)]
    saved, _ = run_selection(tmp_path, monkeypatch, evaluations)
    assert saved == [1000]  # the cheapest (0.90) drifted the SOC on one cycle
    rows = read_evaluations(tmp_path / "evaluations.csv")
    assert [r["qualified"] for r in rows[::2]] == [True, False, True]
    assert selected_step(rows) == 1000


def test_when_no_checkpoint_holds_the_soc_the_least_violating_wins(tmp_path, monkeypatch):
    evaluations = [results(-100.0, 0.95, dsoc=0.05), results(-100.0, 1.10, dsoc=0.03), results(-90.0, 0.90)]
    saved, _ = run_selection(tmp_path, monkeypatch, evaluations)
    assert saved == [1000, 3000]


def test_resumed_run_keeps_the_best_score_of_its_evaluations(tmp_path, monkeypatch):
    run_selection(tmp_path, monkeypatch, [results(-100.0, 1.05), results(-100.0, 1.01)])
    config = build_config("ppo", cycles=["random_bus"], eval_cycles=list(CYCLES), eval_scenarios=["paper"])
    resumed = loop.TrainingRun(config, tmp_path, verbose=0)
    assert resumed.best_score == pytest.approx(1.01)


def test_fuel_ratio_score_penalises_each_violation_and_needs_a_reference():
    ok = fuel_ratio_score(results(0.0, 1.2), REFERENCE)
    one = fuel_ratio_score(results(0.0, 0.8, dsoc=-0.03), REFERENCE)
    assert ok == Score(pytest.approx(1.2), True, (pytest.approx(1.2), pytest.approx(1.2)), 0)
    assert not one.qualified and one.violations == 1 and one.value > ok.value
    assert fuel_ratio_score(results(0.0, 0.8, dsoc=0.02), REFERENCE).qualified  # the limit itself is allowed
    with pytest.raises(KeyError, match="no reference"):
        fuel_ratio_score(results(0.0, 1.0), {})


def test_references_are_computed_once_per_run_and_cycle():
    calls = []
    scorer = Scorer("t", "test", fuel_ratio_score, lambda c, s: calls.append((c, s)) or 30.0 + len(calls))
    ref = compute_references(scorer, CYCLES, ["paper", "full_bus"], known={run_key(CYCLES[0], "paper"): 1.0})
    assert len(calls) == 3 and ref[run_key(CYCLES[0], "paper")] == 1.0 and len(ref) == 4


def test_ecms_reference_is_the_corrected_fuel_of_ecms():
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.runner import run_strategy

    ref = SCORERS["fuel_vs_ecms"].reference("us06", "paper")
    assert ref == pytest.approx(run_strategy(get_strategy("ecms"), "us06", "paper").summary[
        "fuel_corrected_l_per_100km"])


def custom_scorer() -> Scorer:
    """A scorer plugged in by its import path (the shape a DP-frontier scorer takes)."""
    return Scorer("custom", "custom rule", lambda res, ref: Score(float(len(res)), True, tuple(np.nan for _ in res)))


def test_scorers_plug_in_by_import_path_and_unknown_names_fail():
    assert get_scorer("tests.test_selection:custom_scorer").name == "custom"
    with pytest.raises(ValueError, match="registered scorers"):
        get_scorer("fastest")
    with pytest.raises(ValueError, match="cannot import"):
        get_scorer("no.such.module:scorer")


def test_config_rejects_random_scenarios_and_scoring_on_training_cycles():
    with pytest.raises(ValueError, match="fixed"):
        build_config("ppo", eval_scenarios=["random"])
    with pytest.raises(ValueError, match="also a training cycle"):
        build_config("ppo", cycles=["bus_long", "validation_bus:2"])
    with pytest.raises(ValueError, match="also a training cycle"):
        build_config("ppo", cycles=["hwfet"], eval_cycles=["hwfet"])
    cfg = build_config("ppo")
    assert "hwfet" not in cfg["env"]["cycles"] and "beijing" not in cfg["env"]["cycles"]
    assert cfg["eval"]["selection"] == "fuel_vs_ecms" and cfg["env"]["scenario"] == "random_service"
