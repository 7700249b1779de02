"""Choosing ``best_model.zip``: by corrected fuel relative to a reference, never a checkpoint that drifts the SOC,
and the training curve that shows the choice.

The training loop's own ``evaluate`` runs on fabricated evaluation results (no model is trained here)."""

from __future__ import annotations

import pytest

import hev_thermal_env.training.loop as loop
from hev_thermal_env.evaluation.score import SOC_BOUND
from hev_thermal_env.evaluation.styles import close
from hev_thermal_env.training.artifacts import read_evaluations
from hev_thermal_env.training.config import build_config, save_run_config
from hev_thermal_env.training.curves import read_training_returns, selected_step, training_curve_figure
from hev_thermal_env.training.selection import (
    SCORERS,
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

    def get_vec_normalize_env(self):
        return None


def run_selection(tmp_path, monkeypatch, evaluations, selection="fuel_vs_ecms") -> tuple[list[int], object]:
    """Feed ``evaluations`` (one per 1000 env-steps) through ``TrainingRun.evaluate`` with ``eval.selection``
    ``selection``; returns the steps saved as ``best_model.zip`` and the run."""
    saved: list[int] = []
    model = FakeModel()
    monkeypatch.setattr(loop, "LoadedPolicy", lambda model, stats: type("P", (), {"act": None})())
    monkeypatch.setattr(loop, "save_model_and_stats", lambda m, stats, path, spath: saved.append(m.num_timesteps))
    config = build_config("ppo", cycles=["random_bus"], eval_cycles=list(CYCLES), eval_scenarios=["paper"])
    config["result"] = {"selection_reference": dict(REFERENCE)}
    config["eval"]["selection"] = selection
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


def test_a_checkpoint_that_drifts_the_soc_is_not_chosen(tmp_path, monkeypatch):
    evaluations = [results(-100.0, 1.05), results(-60.0, 0.90, dsoc=SOC_BOUND + 0.005), results(-90.0, 1.07)]
    saved, _ = run_selection(tmp_path, monkeypatch, evaluations)
    assert saved == [1000]  # the cheapest (0.90) drifted the SOC on one cycle
    rows = read_evaluations(tmp_path / "evaluations.csv")
    assert [r["qualified"] for r in rows[::2]] == [True, False, True]
    assert selected_step(rows) == 1000


def test_when_no_checkpoint_holds_the_soc_the_least_violating_wins(tmp_path, monkeypatch):
    evaluations = [results(-100.0, 0.95, dsoc=0.05), results(-100.0, 1.10, dsoc=0.03), results(-90.0, 0.90)]
    saved, _ = run_selection(tmp_path, monkeypatch, evaluations)
    assert saved == [1000, 3000]


def test_the_final_selection_keeps_every_latest_evaluation_and_still_scores_it(tmp_path, monkeypatch):
    """``eval.selection: final``: ``best_model.zip`` is the latest evaluation whatever its fuel or charge, so the
    final model; the fuel ÷ ECMS and the SOC check are still written for every evaluation."""
    evaluations = [results(-100.0, 1.02), results(-60.0, 1.10, dsoc=SOC_BOUND + 0.005), results(-90.0, 1.07)]
    saved, _ = run_selection(tmp_path, monkeypatch, evaluations, selection="final")
    assert saved == [1000, 2000, 3000]
    rows = read_evaluations(tmp_path / "evaluations.csv")
    assert selected_step(rows) == 3000 and [r["qualified"] for r in rows[::2]] == [True, False, True]
    assert rows[2]["fuel_ratio"] == pytest.approx(1.10)


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


def test_unknown_scorers_fail():
    with pytest.raises(ValueError, match="registered scorers: fuel_vs_ecms, fuel_vs_rule, final"):
        get_scorer("fastest")
    with pytest.raises(ValueError, match="unknown eval.selection"):
        build_config("ppo", overrides={"eval.selection": "mean_return"})


def test_config_rejects_random_scenarios_and_scoring_on_training_cycles():
    with pytest.raises(ValueError, match="fixed"):
        build_config("ppo", eval_scenarios=["random"])
    with pytest.raises(ValueError, match="also a training cycle"):
        build_config("ppo", cycles=["bus_long", "validation_bus:2"])
    with pytest.raises(ValueError, match="also a training cycle"):
        build_config("ppo", cycles=["hwfet"], eval_cycles=["hwfet"])
    cfg = build_config("ppo")
    assert "hwfet" not in cfg["env"]["cycles"] and "beijing" not in cfg["env"]["cycles"]
    # ppo.yaml keeps the final model
    assert cfg["eval"]["selection"] == "final" and cfg["env"]["scenario"] == "random_service"


# --- training_curve.png -----------------------------------------------------------------------------

def test_training_curve_stars_the_selected_evaluation_on_the_fuel_panel(tmp_path, monkeypatch):
    """The best return (step 2000) is not starred; the best fuel (3000) is; the cheaper drift (4000) is crossed."""
    from stable_baselines3.common.logger import configure

    evaluations = [results(-100.0, 1.05), results(-50.0, 1.10), results(-80.0, 1.02),
                   results(-90.0, 0.95, dsoc=SOC_BOUND + 0.005)]
    _, run = run_selection(tmp_path, monkeypatch, evaluations)
    save_run_config(tmp_path, run.config)
    logger = configure(str(tmp_path / "tb" / "PPO_1"), ["tensorboard"])
    for step in (500, 1000, 1500, 2000, 2500, 3000):
        logger.record("rollout/ep_rew_mean", -100.0 + step / 100)
        logger.record("rollout/ep_len_mean", 300.0)
        logger.dump(step)
    logger.close()
    assert list(read_training_returns(tmp_path)["steps"]) == [500, 1000, 1500, 2000, 2500, 3000]
    fig = training_curve_figure(tmp_path)
    try:
        (training,) = [ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("training episode return")]
        assert list(training.get_xdata()) == [500, 1000, 1500, 2000, 2500, 3000]
        ret_axis = next(ax for ax in fig.axes if ax.get_title().startswith("evaluation return"))
        assert not [ln for ln in ret_axis.get_lines() if ln.get_marker() == "*"]
        fuel_axis = next(ax for ax in fig.axes if "corrected fuel" in ax.get_title())
        (star,) = [ln for ln in fuel_axis.get_lines() if ln.get_marker() == "*"]
        assert list(star.get_xdata()) == [3000] and "corrected fuel ÷ ECMS" in " ".join(star.get_label().split())
        (crossed,) = [ln for ln in fuel_axis.get_lines() if ln.get_marker() == "x"]
        assert list(crossed.get_xdata()) == [4000]
        fig.canvas.draw()
        (legend,) = fig.legends  # outside every panel's data
        assert not any(legend.get_window_extent().overlaps(ax.get_window_extent()) for ax in fig.axes)
    finally:
        close(fig)
