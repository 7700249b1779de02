"""benchmarks/teacher_cost_gap.py end to end on one short route: the teacher's gap to itself is nil, a policy's is not
negative, and the totals are the episode's."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("teacher_cost_gap", ROOT / "benchmarks/teacher_cost_gap.py")
gap = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(gap)  # a script beside the benchmark, not a package module


def test_the_shipped_policy_is_priced_by_its_teacher(tmp_path):
    out = tmp_path / "gap.json"
    policy = str(ROOT / "agents" / "policies" / "ppo_default")
    assert gap.main(["--policy", f"shipped={policy}", "--run", "validation_bus:21/paper", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["runs"]["validation_bus:21/paper"]
    teacher, shipped = rows["teacher"], rows["shipped"]
    assert teacher["excess_g"]["traction"] == pytest.approx(0.0, abs=0.05)
    assert teacher["excess_g"]["braking"] == pytest.approx(0.0, abs=0.05)
    assert shipped["excess_g"]["traction"] > 0.1 and shipped["excess_g"]["braking"] >= 0.0
    for row in (teacher, shipped):
        assert 0.5 < row["soc_final"] < 0.8 and row["fuel_g"] > 100.0 and row["cost"] >= 0.0
        assert row["reward_miss"] <= 0.0 and row["missed_wheel_energy_j"] >= 0.0


def test_bad_arguments_are_named():
    with pytest.raises(SystemExit, match="at least one --policy"):
        gap.main([])
    with pytest.raises(SystemExit, match="CYCLE/SCENARIO"):
        gap.main(["--policy", "a=b", "--run", "hwfet"])
    with pytest.raises(SystemExit, match="--teacher-options is not JSON"):
        gap.main(["--policy", "a=b", "--teacher-options", "{bad"])


def test_the_teacher_is_the_one_the_policies_were_fitted_to_unless_given():
    from types import SimpleNamespace

    def fitted(init):
        return SimpleNamespace(policy=SimpleNamespace(config={"init": init}))

    options = {"x_price": "margin", "k_soc": 1.5}
    one = fitted({"imitate": "ecms_thermal", "teacher_options": options})
    other = fitted({"imitate": "ecms_thermal", "teacher_options": {"x_price": "fixed"}})
    assert gap.policy_teacher.teacher_options(None, {"a": one, "b": one}) == options
    assert gap.policy_teacher.teacher_options({"w_x": 1.0}, {"a": one, "b": other}) == {"w_x": 1.0}
    with pytest.raises(SystemExit, match="fitted to different teachers"):
        gap.policy_teacher.teacher_options(None, {"a": one, "b": other})
    with pytest.raises(SystemExit, match="not fitted to ecms_thermal; give --teacher-options"):
        gap.policy_teacher.teacher_options(None, {"sac": fitted({"imitate": None})})
