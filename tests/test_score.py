"""The normalised score and the task references: 0 for engine_only, 100 for the optimum, nothing far above 100, the
ill-conditioned flag, aggregation, stale references refused, the safety budget's rule, the score on results.md."""

from __future__ import annotations

import json

import pytest

from hev_thermal_env import load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.evaluation import references
from hev_thermal_env.evaluation.results_table import write_results
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.score import (
    ILL_CONDITIONED,
    add_score_columns,
    add_yardstick_columns,
    aggregate,
    normalised_score,
)
from hev_thermal_env.tasks import Task, get_task

CLASSIC = ("rule", "ecms", "aecms", "ecms_thermal", "dp")
OPTIMUM_RATIO_TOLERANCE = 1e-3
"""The optimum's stated tolerance: no run's frontier ratio lies below 1 − this (the grid's resolution)."""


def score_tolerance(anchor_ratio: float) -> float:
    """How far above 100 a score may lie within :data:`OPTIMUM_RATIO_TOLERANCE`, on an episode with ``r0``."""
    return 100.0 * OPTIMUM_RATIO_TOLERANCE / (float(anchor_ratio) - 1.0)


def test_score_formula_not_clipped():
    assert normalised_score(1.30, 1.30) == (0.0, None)
    assert normalised_score(1.0, 1.30) == (100.0, None)
    assert normalised_score(1.15, 1.30)[0] == pytest.approx(50.0)
    assert normalised_score(1.60, 1.30)[0] == pytest.approx(-100.0)  # worse than the motor unused: below 0
    assert normalised_score(0.97, 1.30)[0] == pytest.approx(110.0)  # not clipped
    assert normalised_score(None, 1.3)[0] is None and normalised_score(1.1, None)[0] is None


def test_ill_conditioned_is_flagged_and_left_out():
    score, note = normalised_score(1.005, 1.01)
    assert score == pytest.approx(50.0) and note.startswith(ILL_CONDITIONED)
    assert normalised_score(1.0, 0.999)[0] is None  # r0 below 1: no score at all
    agg = aggregate([[(50.0, note)], [(80.0, None)], [(90.0, None)]])
    assert agg["score"] == pytest.approx(85.0) and agg["excluded"] == 1 and agg["n"] == 2


def test_family_rows_aggregate_their_members():
    rows = [{"cycle": c, "scenario": "paper", "strategy": s, "family": f, "frontier_ratio": r}
            for c, r0 in (("a", 1.2), ("b", 1.4)) for s, f, r in
            (("engine_only", None, r0), ("ppo:1", "fam", 1.1), ("ppo:2", "fam", 1.0))]
    fam = [{"cycle": c, "scenario": sc, "strategy": "fam", "family": "fam"}
           for c, sc in (("a", "paper"), ("b", "paper"), ("all", "all"))]
    rows += fam
    add_score_columns(rows)
    scores = {(r["cycle"], r["strategy"]): r["score"] for r in rows}
    assert scores[("a", "ppo:1")] == pytest.approx(50.0) and scores[("b", "ppo:1")] == pytest.approx(75.0)
    assert scores[("a", "fam")] == pytest.approx(75.0)  # IQM of 50 and 100
    assert scores[("all", "fam")] == pytest.approx((75.0 + 100.0) / 2)  # IQM of 50, 75, 100, 100


def test_budget_rule():
    assert references.safety_budget_s([0.0, 0.0]) == references.BUDGET_FLOOR_S
    assert references.safety_budget_s([100.0, 40.0]) == pytest.approx(100.0 * (1 + references.BUDGET_MARGIN))


@pytest.fixture(scope="module")
def tiny_task(tmp_path_factory) -> Task:
    """200 s of Beijing in the hot scenario (the motor near its limits), as a task."""
    path = tmp_path_factory.mktemp("score") / "beijing_200s.csv"
    v = load_cycle("beijing").speed_mps[:201]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return Task("tiny", 1, "200 s of Beijing, hot", (str(path),), "hot")


@pytest.fixture(scope="module")
def tiny_reference(tiny_task):
    return references.compute_reference(tiny_task)


def test_optimum_scores_100_engine_only_0_and_no_strategy_beats_it(tiny_reference, tiny_task):
    ep = tiny_reference["episodes"][0]
    r0 = ep["anchor"]["frontier_ratio"]
    assert r0 - 1.0 > 0.02  # the motor saves something here: the score is well conditioned
    _, opt_score, note = references.episode_score(ep, ep["optimum"]["cost_g"], ep["optimum"]["soc_final"])
    tol = score_tolerance(r0)
    assert note is None and abs(opt_score - 100.0) <= tol
    anchor_score = references.episode_score(ep, ep["anchor"]["cost_g"], ep["anchor"]["soc_final"])[1]
    assert anchor_score == pytest.approx(0.0, abs=1e-9)
    for name in CLASSIC:
        s = run_strategy(get_strategy(name), tiny_task.cycles[0], "hot").summary
        ratio, score, _ = references.episode_score(ep, s["cost_g"], s["soc_final"])
        assert ratio >= 1.0 - OPTIMUM_RATIO_TOLERANCE, name
        assert score <= 100.0 + tol, (name, score)


def test_stale_reference_is_refused_naming_both(tiny_reference, tmp_path):
    task = get_task("hwfet")
    record = {**tiny_reference, "task": task.id, "task_digest": task.digest(), "physics_fingerprint": "0" * 16}
    (tmp_path / f"{task.id}.json").write_text(json.dumps(record))
    with pytest.raises(references.StaleReferenceError, match=f"'{'0' * 16}'.*current '{task.fingerprint()}'"):
        references.load_reference("hwfet", tmp_path)
    record.update(physics_fingerprint=task.fingerprint(), task_digest="f" * 64)
    (tmp_path / f"{task.id}.json").write_text(json.dumps(record))
    with pytest.raises(references.StaleReferenceError, match=r"task digest ffff.*current " + task.digest()[:16]):
        references.load_reference("hwfet", tmp_path)
    record.update(task_digest=task.digest())
    (tmp_path / f"{task.id}.json").write_text(json.dumps(record))
    assert references.load_reference("hwfet", tmp_path)["task"] == task.id
    with pytest.raises(FileNotFoundError, match=f"evaluate.py reference --task {get_task('beijing').id}"):
        references.load_reference("beijing", tmp_path)


def test_stored_references_are_current():
    """Every reference in the package belongs to the current physics and task definition (else recompute it)."""
    stored = sorted(references.REFERENCE_DIR.glob("*.json"))
    assert stored, "no stored reference"
    for path in stored:
        ref = references.load_reference(path.stem)
        optimum_costs = [e["optimum"]["safety_cost_s"] for e in ref["episodes"]]
        assert ref["safety_budget_s"] == references.safety_budget_s(optimum_costs)


def test_results_table_carries_the_score(tmp_path):
    rows = []
    for strategy, cost, soc in (("engine_only", 130.0, 0.6), ("rule", 115.0, 0.6), ("dp_thermal", 100.0, 0.6)):
        rows.append({"cycle": "c", "scenario": "paper", "strategy": strategy, "cost_g": cost, "soc_final": soc,
                     "fuel_g": cost, "fuel_l_per_100km": 1.0, "fuel_corrected_l_per_100km": cost / 100,
                     "miss_correction_l_per_100km": 0.0, "distance_km": 1.0, "soc_initial": 0.6,
                     "max_motor_temp_c": 40.0, "heat_index_max": 0.0, "derated_s": 0, "cutoff_s": 0,
                     "missed_wheel_energy_kwh": 0.0, "net_energy_ratio": 0.0, "charge_sustaining": True,
                     "strategy_settings": {"frontier": {"soc_final": [0.5, 0.7], "cost_g": [100.0, 100.0]}}
                     if strategy == "dp_thermal" else {}})
    add_yardstick_columns(rows)
    write_results(tmp_path, rows, wall_s=0.0)
    data = json.loads((tmp_path / "results.json").read_text())
    scores = {r["strategy"]: r["score"] for r in data["rows"]}
    assert scores == {"engine_only": 0.0, "rule": pytest.approx(50.0), "dp_thermal": 100.0}
    md = (tmp_path / "results.md").read_text()
    assert "| score |" in md and "| 50.0 |" in md


#: Episodes of a task checked against its stored reference, its shortest (the generalisation task has 18 long routes).
EPISODES_CHECKED = 3


@pytest.mark.full
def test_no_strategy_above_100_on_the_stored_tasks():
    """On every task with a stored reference (its shortest episodes), no classic strategy nor the shipped policy
    scores above 100 by more than the optimum's tolerance, and engine_only scores 0."""
    for path in sorted(references.REFERENCE_DIR.glob("*.json")):
        ref = references.load_reference(path.stem)
        task = get_task(path.stem)
        shortest = sorted(ref["episodes"], key=lambda e: load_cycle(e["cycle"]).n_steps)[:EPISODES_CHECKED]
        for ep in shortest:
            for name in ("engine_only", *CLASSIC, "ppo"):
                s = run_strategy(get_strategy(name), ep["cycle"], task.scenario, seed=ep["seed"],
                                 physics=task.physics).summary
                _, score, _ = references.episode_score(ep, s["cost_g"], s["soc_final"])
                if score is not None:
                    assert score <= 100.0 + score_tolerance(ep["anchor"]["frontier_ratio"]), (path.stem, name, score)
                if name == "engine_only":
                    assert score == pytest.approx(0.0, abs=1e-9)


def test_the_reference_frontier_reaches_the_anchors_final_charge():
    """Without regeneration engine_only can end far below the start: the reference's optimum then keeps a frontier
    reaching 0.01 below it (else r0 has no frontier to be read from); within the default's reach, the default."""
    assert references.frontier_halfwidth_for(0.65, 0.60) is None  # 0.06 below: the default 0.08 reaches it
    assert references.frontier_halfwidth_for(0.65, 0.58) is None  # exactly the default with the margin
    assert references.frontier_halfwidth_for(0.65, 0.52) == pytest.approx(0.14)
    assert references.frontier_halfwidth_for(0.65, 0.4905) == pytest.approx(0.17)  # rounded up to 0.01


def test_reference_table_names_every_task_and_goes_between_the_markers(tmp_path, capsys):
    from hev_thermal_env.cli.evaluate import main
    from hev_thermal_env.tasks import list_tasks

    table = references.references_table()
    assert [line.split(" | ")[0][3:-1] for line in table.splitlines()[2:]] == [get_task(t).id for t in list_tasks()]
    doc = tmp_path / "tasks.md"
    doc.write_text(f"intro\n{references.TABLE_BEGIN}\nold table\n{references.TABLE_END}\nafter\n")
    assert main(["reference", "--table", str(doc)]) == 0
    assert doc.read_text() == f"intro\n{references.TABLE_BEGIN}\n{table}{references.TABLE_END}\nafter\n"
    (tmp_path / "plain.md").write_text("no markers\n")
    assert main(["reference", "--table", str(tmp_path / "plain.md")]) == 2
    assert "plain.md: needs one line <!-- references:begin -->" in capsys.readouterr().err
    assert main(["reference", "--task", "hwfet", "--check"]) == 0
    assert f"{get_task('hwfet').id}: current" in capsys.readouterr().out
    assert main(["reference", "--task", "hwfet", "--jobs", "0"]) == 2
    assert "--jobs must be at least 1, got 0" in capsys.readouterr().err


def test_the_tasks_page_shows_the_stored_references():
    """docs/tasks.md's table is the stored references' (``evaluate.py reference --table docs/tasks.md`` writes it)."""
    text = (references.REFERENCE_DIR.parents[2] / "docs" / "tasks.md").read_text()
    assert text.split(references.TABLE_BEGIN + "\n")[1].split(references.TABLE_END)[0] == references.references_table()


@pytest.mark.full
def test_reference_in_two_processes_equals_the_serial_one(tmp_path, tiny_task):
    """``jobs=2`` solves the episodes in two processes (longest first) and stores the same record, in task order."""
    short = tmp_path / "beijing_120s.csv"
    v = load_cycle("beijing").speed_mps[300:421]
    short.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    task = Task("tiny2", 1, "120 s and 200 s of Beijing, hot", (str(short), tiny_task.cycles[0]), "hot")
    timing = ("optimum_wall_s", "optimum_plan_s", "plan_from_cache")
    records = [references.compute_reference(task, jobs=jobs) for jobs in (2, 1)]
    episodes = [[{k: v for k, v in e.items() if k not in timing} for e in r["episodes"]] for r in records]
    assert [e["cycle"] for e in episodes[0]] == list(task.cycles)
    assert episodes[0] == episodes[1]
    assert records[0]["jobs"] == 2 and all(e["optimum_plan_s"] > 0 for e in records[0]["episodes"])
