"""The heat rule of PPO's selection (benchmarks/selection_heat.py) end to end on one short selection route."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("selection_heat", ROOT / "benchmarks/selection_heat.py")
sh = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(sh)  # a script beside the benchmark, not a package module


@pytest.mark.full
def test_candidates_are_scored_against_the_optimum_and_ecms_thermal(tmp_path, capsys):
    """``ecms_thermal`` as the leaderboard runs it is its own yardstick in the heat (fuel ratio 1, the same safety
    cost); no candidate beats the optimum; the references are solved once and then reused."""
    out, refs = tmp_path / "selection.json", tmp_path / "refs"
    args = ["--routes", "validation_bus:21", "--heat-routes", "validation_bus:21", "--references", str(refs),
            "--teacher", "leaderboard's={}", "--teacher", 'floor={"x_price": "margin", "margin_floor": 0.5}',
            "--out", str(out)]
    assert sh.main(args) == 0
    assert "solving the optimum on selection-paper-v1" in capsys.readouterr().out
    record = json.loads(out.read_text())
    assert set(record["candidates"]) == {"leaderboard's", "floor"}
    for row in record["candidates"].values():
        for task in ("selection-paper-v1", "selection-summer-v1", "selection-hilly-v1"):
            cell = row[task]
            assert cell["frontier_ratio_mean"] >= 0.999 and cell["frontier_ratio_worst"] >= cell["frontier_ratio_mean"]
            assert cell["beyond_soc_bound"] == 0 and cell["above_optimum_safety"] in (0, 1)
            assert cell["frontier_ratios"] == [cell["frontier_ratio_mean"]]  # one route
    same = record["candidates"]["leaderboard's"]
    for scenario in ("summer", "hilly"):
        cell = same[f"{scenario} vs ecms_thermal"]
        assert cell["fuel_vs_ecms_thermal_mean"] == 1.0 and cell["safety_cost_s"] == cell["ecms_thermal_safety_cost_s"]
        assert cell["cost_vs_ecms_thermal_mean"] == 1.0 == cell["cost_vs_ecms_thermal_worst"]
        assert cell["cost_above_ecms_thermal_1pct"] == 0
    assert sh.main(args) == 0  # the second run reads the references
    assert "solving" not in capsys.readouterr().out


def test_bad_candidates_are_named():
    with pytest.raises(SystemExit, match=r"--teacher 'x=\{bad': the options are not JSON"):
        sh.parse_candidates([], ["x={bad"])
    with pytest.raises(SystemExit, match="--policy 'nopath': expected NAME=RUN_DIR_OR_ZIP"):
        sh.parse_candidates(["nopath"], [])
    with pytest.raises(SystemExit, match="at least one"):
        sh.parse_candidates([], [])


def test_the_hilly_routes_may_be_more_than_the_summer_ones():
    """``--hilly-routes``: the hilly task scores its own routes (the motorway ones, where the policy derates most),
    the summer task keeps ``--heat-routes``."""
    paper, summer, hilly = sh.selection_tasks(("validation_bus:20", "validation_bus:25"), ("validation_bus:20",),
                                              ("validation_bus:20", "validation_bus:25"))
    assert paper.scenario == "paper" and summer.cycles == ("validation_bus:20",)
    assert hilly.scenario == "hilly" and hilly.cycles == ("validation_bus:20", "validation_bus:25")
    assert sh.selection_tasks(("validation_bus:20",), ("validation_bus:21",))[2].cycles == ("validation_bus:21",)


def test_further_routes_and_proxy_scenarios():
    """``--express-routes`` adds a fourth task in ``paper`` scored against the optimum; ``--proxies`` chooses the
    scenarios scored against ``ecms_thermal``."""
    tasks = sh.selection_tasks(("validation_bus:20",), ("validation_bus:20",), None, ("bus_express:2147483756",))
    assert [t.id for t in tasks][-1] == "selection-express-v1"
    assert tasks[-1].scenario == "paper" and tasks[-1].cycles == ("bus_express:2147483756",)
    assert len(sh.selection_tasks(("validation_bus:20",), ("validation_bus:20",))) == 3
    assert [t.scenario for t in sh.proxy_tasks(("validation_bus:20",), ("summer", "hilly", "hot"))] == [
        "summer", "hilly", "hot"]
    assert [t.scenario for t in sh.proxy_tasks(("validation_bus:20",))] == list(sh.PROXY_SCENARIOS)


def test_hot_routes_and_scenarios_without_routes():
    """``--hot-routes`` adds a task in ``hot`` scored against the optimum; a scenario given no routes has no task (the
    optimum is not solved there)."""
    tasks = sh.selection_tasks(("bus_long:2147483848",), (), (), (), ("bus_long:2147483848", "bus_express:2147483853"))
    assert [(t.id, t.scenario) for t in tasks] == [("selection-paper-v1", "paper"), ("selection-hot-v1", "hot")]
    assert tasks[1].cycles == ("bus_long:2147483848", "bus_express:2147483853")
    assert [t.scenario for t in sh.selection_tasks(("validation_bus:20",), (), None)] == ["paper"]
    assert [t.scenario for t in sh.selection_tasks(("validation_bus:20",), ("validation_bus:21",), ())] == [
        "paper", "summer"]


def test_one_run_above_ecms_thermal_by_more_than_a_percent_is_counted():
    rows = [{"fuel_corrected_l_per_100km": 30.0, "cost_g": c, "safety_cost_s": 0.0} for c in (100.0, 100.5, 103.0)]
    base = [{"fuel_corrected_l_per_100km": 30.0, "cost_g": 100.0, "safety_cost_s": 0.0}] * 3
    cell = sh.against_ecms_thermal({"episodes": rows}, {"episodes": base})
    assert cell["cost_above_ecms_thermal_1pct"] == 1 and cell["cost_vs_ecms_thermal_worst"] == pytest.approx(1.03)
    assert cell["cost_vs_ecms_thermal_mean"] == pytest.approx(1.0117, abs=1e-4)


def test_the_command_line_leaves_out_a_scenario_given_no_routes():
    """``--heat-routes`` and ``--hilly-routes`` given no routes: no summer and no hilly task; ``--hot-routes``: a task
    in ``hot``; without the options the summer and hilly tasks score the default heat routes."""
    args = sh.build_parser().parse_args(["--routes", "bus_long:2147483848", "--heat-routes", "--hilly-routes",
                                         "--hot-routes", "bus_long:2147483848", "--policy", "a=b"])
    assert args.heat_routes == [] and args.hilly_routes == [] and args.hot_routes == ["bus_long:2147483848"]
    assert [(t.id, t.cycles) for t in sh.tasks_of(args)] == [("selection-paper-v1", ("bus_long:2147483848",)),
                                                             ("selection-hot-v1", ("bus_long:2147483848",))]
    plain = sh.tasks_of(sh.build_parser().parse_args(["--policy", "a=b"]))
    assert [t.scenario for t in plain] == ["paper", "summer", "hilly"]
    assert plain[2].cycles == plain[1].cycles == sh.HEAT_ROUTES


def test_a_candidate_drives_each_set_of_episodes_once(monkeypatch):
    """A task scored against the optimum and a proxy on the same routes and scenario share the candidate's runs."""
    from hev_thermal_env.evaluation import submission

    calls = []
    monkeypatch.setattr(submission, "result_of_strategy",
                        lambda task, strategy, name: calls.append(task.id) or {"task": task.id})
    drive = sh.driver(object(), "candidate")
    hot = sh.selection_tasks(("validation_bus:20",), (), (), (), ("validation_bus:20",))[1]
    proxy_hot, proxy_summer = sh.proxy_tasks(("validation_bus:20",), ("hot", "summer"))
    assert drive(hot) is drive(proxy_hot) and drive(proxy_summer)["task"] == "selection-summer-all-v1"
    assert calls == ["selection-hot-v1", "selection-summer-all-v1"]
