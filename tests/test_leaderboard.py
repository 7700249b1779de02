"""The result format for outside methods (clear errors on bad files, the info tally equals the package's metrics) and
the leaderboard command on tiny inputs (a synthetic reference, two real strategies, one outside result)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cli.evaluate import main as evaluate_main
from hev_thermal_env.evaluation.leaderboard import PROFILE_FILE, score_result
from hev_thermal_env.evaluation.references import BUDGET_RULE, load_reference
from hev_thermal_env.evaluation.references import FORMAT as REFERENCE_FORMAT
from hev_thermal_env.evaluation.submission import (
    FORMAT,
    EpisodeTally,
    ResultFormatError,
    load_result,
    result_of_seeds,
    result_of_strategy,
    validate_result,
)
from hev_thermal_env.tasks import get_task, make_task


def hwfet_fingerprint() -> str:
    return get_task("hwfet").fingerprint()


@pytest.fixture(scope="module")
def good() -> dict:
    task = get_task("hwfet")
    return {"format": FORMAT, "task": task.id, "physics_fingerprint": hwfet_fingerprint(), "method": "outside",
            "seeds": [0, 1], "wall_clock_s": 12.0,
            "episodes": [{"seed": s, "cycle": "hwfet", "env_seed": 0, "cost_g": 3000.0 - 100 * s, "soc_final": 0.6,
                          "safety_cost_s": 3.0 * s} for s in (0, 1)]}


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("method"), "missing field.*method"),
    (lambda d: d.update(format="v0"), "format 'v0', expected 'hev-thermal-result-v1'"),
    (lambda d: d.update(task="nope-v1"), "task: unknown task 'nope-v1'"),
    (lambda d: d.update(task="hwfet"), r"name the version \(hwfet-v2\)"),
    (lambda d: d.update(seeds=[0, 0]), "seeds: expected a non-empty list of distinct integers"),
    (lambda d: d["episodes"][1].update(cost_g="12"), r"episodes\[1\]\.cost_g: expected a finite number ≥ 0, got '12'"),
    (lambda d: d["episodes"][0].update(soc_final=1.7), r"episodes\[0\]\.soc_final: .*in \[0, 1\], got 1.7"),
    (lambda d: d["episodes"][0].pop("safety_cost_s"), r"episodes\[0\]: missing safety_cost_s"),
    (lambda d: d["episodes"][0].update(cycle="udds"), r"episodes\[0\]: .*'udds'.* is not an episode of hwfet-v2"),
    (lambda d: d["episodes"].pop(), r"1 episode\(s\) missing, e.g. .*\(1, 'hwfet', 0\)"),
    (lambda d: d.update(physics_fingerprint="abc"), "physics fingerprint 'abc' .current"),
    (lambda d: d.update(training=[1.0]), "training: expected an object"),
    (lambda d: d.update(training={"wall_clock_s_per_seed": [60.0]}),
     r"training\.wall_clock_s_per_seed: expected one number per seed \(2\)"),
    (lambda d: d.update(training={"wall_clock_s_per_seed": [60.0, -1.0]}),
     r"training\.wall_clock_s_per_seed\[1\]: expected a finite number ≥ 0, got -1.0"),
    (lambda d: d.update(track="rl"), "track: expected one of RL, guided, got 'rl'"),
])
def test_bad_result_files_give_clear_errors(good, change, message, tmp_path):
    data = copy.deepcopy(good)
    change(data)
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=message) as info:
        load_result(path)
    assert str(path) in str(info.value)


def test_unreadable_result_file(tmp_path):
    path = tmp_path / "r.json"
    path.write_text("{not json")
    with pytest.raises(ResultFormatError, match=f"{path}: not JSON"):
        load_result(path)
    assert validate_result(copy.deepcopy(json.loads(json.dumps(good_dict()))))["method"] == "outside"


def good_dict() -> dict:
    return {"format": FORMAT, "task": "hwfet-v2", "physics_fingerprint": hwfet_fingerprint(), "method": "outside",
            "seeds": [0], "episodes": [{"seed": 0, "cycle": "hwfet", "cost_g": 1.0, "soc_final": 0.6,
                                        "safety_cost_s": 0.0}]}


def test_info_tally_equals_the_runners_metrics():
    """An outside method adds up the infos (EpisodeTally); the package's runner computes the cost from the physics'
    outputs: the same episode gives the same row."""
    task = get_task("udds-hot")
    env = make_task(task)
    strategy = get_strategy("rule")
    (seed, options), = task.resets()
    obs, info = env.reset(seed=seed, options=options)
    strategy.reset(env)
    tally, done = EpisodeTally(), False
    while not done:
        obs, _, terminated, truncated, info = env.step(strategy.act(obs, info))
        tally.add(info)
        done = terminated or truncated
    row = tally.row(0, options["cycle"], seed)
    ref = result_of_strategy(task, "rule")["episodes"][0]
    for key in ("cost_g", "soc_final", "safety_cost_s", "fuel_g"):
        assert row[key] == pytest.approx(ref[key], rel=1e-9), key
    assert row["safety_cost_s"] > 100.0  # the hot task derates the thermal-blind rule strategy


def synthetic_reference(r0_cost: float) -> dict:
    """A reference of hwfet-v2 with a flat frontier of 1000 g and an anchor at ``r0_cost``."""
    task = get_task("hwfet")
    ep = {"cycle": "hwfet", "seed": 0, "frontier": {"soc_final": [0.3, 0.9], "cost_g": [1000.0, 1000.0],
                                                     "grid": "synthetic", "soc_min": 0.3},
          "optimum": {"cost_g": 1000.0, "soc_final": 0.6, "frontier_ratio": 1.0, "safety_cost_s": 0.0},
          "anchor": {"cost_g": r0_cost, "soc_final": 0.6, "frontier_ratio": r0_cost / 1000.0, "safety_cost_s": 0.0}}
    return {"format": REFERENCE_FORMAT, "task": task.id, "task_digest": task.digest(),
            "physics_fingerprint": hwfet_fingerprint(), "safety_budget_s": 10.0, "budget_rule": BUDGET_RULE,
            "episodes": [ep]}


def test_score_result_against_a_reference(good):
    entry = score_result(good, synthetic_reference(4000.0))
    # costs 3000 and 2900 against 1000 with r0 = 4: scores 100·(4−3)/3 and 100·(4−2.9)/3
    assert sorted(entry["scores"]) == pytest.approx([100 / 3, 110 / 3])
    assert entry["score"] == pytest.approx(np.mean([100 / 3, 110 / 3]))
    assert entry["within_budget"] == 2 and entry["safety_cost_max_s"] == 3.0


def test_score_result_counts_runs_beyond_the_charge_bound_and_above_the_optimums_safety(good):
    """Safety is judged against the optimum's own on the episode (+5 %) where it derates at all, and a run's charge by
    its own start: 3 s against the optimum's 2 s is above it, 2.09 s is within 5 %; ΔSOC 0.021 is beyond 0.02."""
    ref = synthetic_reference(4000.0)
    assert score_result(good, ref)["above_optimum_safety"] == 0  # the optimum does not derate here: nothing to match
    ref["episodes"][0]["optimum"]["safety_cost_s"] = 2.0
    rows = good["episodes"]
    rows[0].update(safety_cost_s=2.09, soc_initial=0.6, soc_final=0.579)
    rows[1].update(safety_cost_s=3.0, soc_initial=0.6, soc_final=0.619)
    entry = score_result(good, ref)
    assert entry["above_optimum_safety"] == 1 and entry["beyond_soc_bound"] == 1


def test_leaderboard_command_on_tiny_inputs(good, tmp_path, capsys):
    refs = tmp_path / "refs"
    refs.mkdir()
    engine_only = result_of_strategy("hwfet", "engine_only")["episodes"][0]["cost_g"]
    (refs / "hwfet-v2.json").write_text(json.dumps(synthetic_reference(engine_only)))
    outside = tmp_path / "outside.json"
    outside.write_text(json.dumps({**good, "training": {"wall_clock_s_per_seed": [60.0, 120.0], "timesteps": 1000}}))
    page = tmp_path / "board" / "leaderboard.md"
    code = evaluate_main(["leaderboard", "--tasks", "hwfet", "--methods", "engine_only", "rule", "--references",
                          str(refs), "--results-dir", str(tmp_path / "res"), "--results", str(outside),
                          "--out", str(page)])
    assert code == 0
    md = page.read_text()
    assert "### hwfet-v2" in md and "| engine_only | - | 0.0 |" in md and "| rule | - |" in md
    assert f"## On physics v2 (`HevThermal-v2`, fingerprint `{hwfet_fingerprint()}`)" in md
    # training per seed: the mean of 60 and 120 s; a result that states no track says so
    assert "| outside | unstated | 1 | 50.0 [48.7, 51.3] | 2 | 1.5 min |" in md
    row = next(line for line in md.splitlines() if line.startswith("| outside | unstated | 50.0"))
    assert "| 2/2 | 0/2 |" in row  # both within the 10 s budget; the optimum does not derate, so none above it
    assert "| rule | - | 1 | " in md and md.split("| rule | - | 1 | ")[1].split("\n")[0].endswith("| 1 | - |")
    assert (page.parent / PROFILE_FILE).stat().st_size > 10_000
    assert (tmp_path / "res" / "hwfet-v2" / "rule.json").is_file()
    assert evaluate_main(["leaderboard", "--tasks", "beijing", "--references", str(refs), "--out", str(page)]) == 2
    assert "no reference for beijing-v2" in capsys.readouterr().err


def test_the_optimum_is_asked_for_the_frontier_its_reference_was_solved_with(tmp_path, monkeypatch):
    """The leaderboard's optimum row reuses the reference's plan: an episode whose reference was solved with a wider
    frontier gets that width (its plan's key), the others and every other strategy their defaults; the width comes
    from the references directory given (``evaluate.py leaderboard --references DIR``)."""
    from hev_thermal_env.evaluation import submission

    task = get_task("hwfet")
    episode = {"cycle": "hwfet", "seed": 0, "frontier_halfwidth": 0.13}
    (tmp_path / f"{task.id}.json").write_text(json.dumps(
        {"format": REFERENCE_FORMAT, "task": task.id, "task_digest": task.digest(), "physics_fingerprint":
         hwfet_fingerprint(), "safety_budget_s": 10.0, "episodes": [episode]}))
    asked = []

    def spy(name, **options):
        asked.append((name, options))
        return get_strategy("engine_only")  # the run itself is not what is tested

    monkeypatch.setattr(submission, "get_strategy", spy)
    for name in ("dp_thermal", "rule"):
        result_of_strategy(task, name, references=tmp_path)
    result_of_strategy(task, "dp_thermal", references=tmp_path, frontier_halfwidth=0.2)  # options given: those
    assert asked == [("dp_thermal", {"frontier_halfwidth": 0.13}), ("rule", {}),
                     ("dp_thermal", {"frontier_halfwidth": 0.2})]
    episode.pop("frontier_halfwidth")  # a reference that records none (solved with the default)
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain" / f"{task.id}.json").write_text(json.dumps(
        {"format": REFERENCE_FORMAT, "task": task.id, "task_digest": task.digest(), "physics_fingerprint":
         hwfet_fingerprint(), "safety_budget_s": 10.0, "episodes": [episode]}))
    asked.clear()
    result_of_strategy(task, "dp_thermal", references=tmp_path / "plain")
    assert asked == [("dp_thermal", {})]


def test_a_seed_family_result_has_every_seeds_episodes():
    result = result_of_seeds("hwfet", {3: "engine_only", 7: "rule"}, "family",
                             training={"wall_clock_s_per_seed": [1.0, 2.0]})
    assert result["seeds"] == [3, 7] and [r["seed"] for r in result["episodes"]] == [3, 7]
    assert result["training"]["wall_clock_s_per_seed"] == [1.0, 2.0]
    alone = result_of_strategy("hwfet", "rule")["episodes"][0]
    assert result["episodes"][1]["cost_g"] == alone["cost_g"] and alone["soc_initial"] == pytest.approx(0.65, abs=0.2)
    with pytest.raises(ValueError, match="no seeds"):
        result_of_seeds("hwfet", {}, "family")


def test_the_optimums_row_is_its_stored_reference_run_without_a_solve(tmp_path, monkeypatch):
    from hev_thermal_env.evaluation import leaderboard

    refs = tmp_path / "refs"
    refs.mkdir()
    (refs / "hwfet-v2.json").write_text(json.dumps(synthetic_reference(4000.0)))

    def no_solve(*args, **kwargs):
        raise AssertionError("the optimum was solved")

    monkeypatch.setattr(leaderboard, "result_of_strategy", no_solve)
    [path] = leaderboard.ensure_results(tmp_path / "res", ["hwfet"], ["dp_thermal"], references=refs)
    result = load_result(path)
    assert result["method"] == "dp_thermal" and result["episodes"][0]["cost_g"] == 1000.0
    entry = score_result(result, load_reference("hwfet", refs))
    assert entry["score"] == pytest.approx(100.0) and entry["frontier_ratio"] == pytest.approx(1.0)


def test_the_shipped_policys_stored_result_is_redone_once_the_policy_changes(tmp_path, monkeypatch):
    """The ``ppo`` row is reused while the shipped policy's files are the same and driven again once they change (a
    retrained policy): its result records their digest."""
    from hev_thermal_env.evaluation import leaderboard

    refs = tmp_path / "refs"
    refs.mkdir()
    (refs / "hwfet-v2.json").write_text(json.dumps(synthetic_reference(4000.0)))
    runs: list[str] = []

    def fake_run(task, method, references=None):
        runs.append(method)
        return leaderboard.result_of_reference(task, references) | {"method": method}

    monkeypatch.setattr(leaderboard, "result_of_strategy", fake_run)
    digest = {"value": "aaaa"}
    monkeypatch.setattr(leaderboard, "shipped_policy_digest", lambda: digest["value"])
    [path] = leaderboard.ensure_results(tmp_path / "res", ["hwfet"], ["ppo"], references=refs)
    assert runs == ["ppo"] and load_result(path)["policy_digest"] == "aaaa"
    leaderboard.ensure_results(tmp_path / "res", ["hwfet"], ["ppo"], references=refs)
    assert runs == ["ppo"]  # the same policy: reused
    digest["value"] = "bbbb"
    leaderboard.ensure_results(tmp_path / "res", ["hwfet"], ["ppo"], references=refs)
    assert runs == ["ppo", "ppo"] and load_result(path)["policy_digest"] == "bbbb"


def test_the_shipped_policys_digest_covers_its_model_and_statistics():
    from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR
    from hev_thermal_env.evaluation.leaderboard import shipped_policy_digest

    assert (DEFAULT_POLICY_DIR / "model.zip").is_file() and (DEFAULT_POLICY_DIR / "vecnormalize.pkl").is_file()
    assert len(shipped_policy_digest()) == 16 and shipped_policy_digest() == shipped_policy_digest()


def test_profile_tells_every_method_apart_past_the_palette():
    """25 methods: the palette has 20 colours, so the line styles change past it and no two curves look alike; the
    legend sits beside the axes, not over the curves."""
    from hev_thermal_env.evaluation.leaderboard import profile_figure
    from hev_thermal_env.evaluation.plots import pyplot

    entries = [{"method": f"method {i:02d}", "task": "hwfet-v2", "scores": [90.0 + i / 10, 95.0], "excluded": 0}
               for i in range(25)]
    fig = profile_figure(entries)
    try:
        lines = [ln for ln in fig.axes[1].get_lines() if ln.get_label().startswith("method")]
        looks = {(tuple(ln.get_color()), ln.get_linestyle()) for ln in lines}
        assert len(lines) == 25 and len(looks) == 25
        assert len(fig.legends) == 1 and fig.axes[0].get_legend() is None
    finally:
        pyplot().close(fig)


def test_the_track_is_read_from_the_training_config():
    """A run whose start imitates a strategy is guided, whatever else it sets; a constraint on the env's own safety
    cost or the reward's settings leave it on the RL track. The package's files: PPO and PPO-Lagrangian start from
    ecms_thermal's actions, SAC, TQC and RecurrentPPO learn from the reward alone."""
    from hev_thermal_env.evaluation.submission import track_of
    from hev_thermal_env.training.hyperparams import load_hyperparams

    assert track_of({"init": {"imitate": "ecms_thermal"}}) == "guided"
    assert track_of({"init": {"imitate": None, "episodes": 60}, "constraint": {"budget_s_per_h": 36.0},
                     "env": {"reward": {"descent_recovery": 0.15}}}) == "RL"
    assert track_of({}) == "RL" and track_of({"init": None}) == "RL"
    tracks = {a: track_of(load_hyperparams(a)) for a in ("ppo", "ppo_lagrangian", "sac", "tqc", "recurrent_ppo")}
    assert tracks == {"ppo": "guided", "ppo_lagrangian": "guided", "sac": "RL", "tqc": "RL", "recurrent_ppo": "RL"}


def test_one_row_per_method_and_track(good):
    """The same method name on both tracks is two rows, in the overall table and per task; the RL track comes before
    the guided one, and every learned row says its track."""
    from hev_thermal_env.evaluation.leaderboard import markdown, overall

    ref = synthetic_reference(4000.0)
    rl, guided = ({**copy.deepcopy(good), "method": "PPO", "track": t} for t in ("RL", "guided"))
    guided["episodes"][0]["cost_g"] = 1500.0
    entries = [score_result(guided, ref), score_result(rl, ref)]
    assert [(o["method"], o["track"]) for o in overall(entries)] == [("PPO", "RL"), ("PPO", "guided")]
    md = markdown(entries, [], None)
    assert md.count("| PPO | RL | 1 |") == 1 and md.count("| PPO | guided | 1 |") == 1
    assert md.count("| PPO | RL | ") == 2 and md.count("| PPO | guided | ") == 2


def test_the_shipped_policy_is_driven_on_the_tasks_of_its_own_physics(tmp_path, monkeypatch):
    """The shipped policy's config names the physics it was trained on: the ``ppo`` row is on those tasks only, and its
    result states the config's track."""
    from hev_thermal_env.evaluation import leaderboard

    monkeypatch.setattr(leaderboard, "result_of_strategy", lambda task, method, references=None:
                        leaderboard.result_of_reference(task, references) | {"method": method})
    refs = tmp_path / "refs"
    refs.mkdir()
    (refs / "hwfet-v2.json").write_text(json.dumps(synthetic_reference(4000.0)))
    config = leaderboard.shipped_policy_config()
    assert config["versions"]["physics_fingerprint"] == get_task("hwfet").fingerprint()
    [path] = leaderboard.ensure_results(tmp_path / "res", ["hwfet"], ["ppo"], references=refs)
    assert load_result(path)["track"] == "guided"  # its start imitates ecms_thermal
    monkeypatch.setattr(leaderboard, "shipped_policy_config", lambda: {**config, "versions": {
        "physics_fingerprint": get_task("hwfet-v1").fingerprint()}})
    assert leaderboard.ensure_results(tmp_path / "other", ["hwfet"], ["ppo"], references=refs) == []
