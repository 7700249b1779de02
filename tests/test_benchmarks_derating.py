"""benchmarks/derating_diagnosis.py end to end on a short route and one teacher episode."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("derating_diagnosis", ROOT / "benchmarks/derating_diagnosis.py")
dd = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(dd)  # a script beside the benchmark, not a package module


def test_the_shipped_policy_is_diagnosed_beside_its_teacher(tmp_path):
    """The route figures are physical (a share, a temperature above the ambient, a cost in seconds), the fit's bands
    cover every state once, and the teacher's own actions are the labels (the teacher agrees with itself)."""
    out = tmp_path / "diag.json"
    policy = str(ROOT / "agents" / "policies" / "ppo_default")
    assert dd.main(["--policy", f"shipped={policy}", "--cycle", "validation_bus:21", "--scenario", "paper",
                    "--episodes", "1", "--out", str(out)]) == 0
    record = json.loads(out.read_text())
    for route in (record["teacher"]["route"], record["policies"]["shipped"]["route"]):
        assert route["safety_cost_s"] >= 0.0 and 20.0 <= route["motor_temp_max_c"] < 70.0
        assert route["x_rising_braking_share"] is None or 0.0 <= route["x_rising_braking_share"] <= 1.0
    fit = record["policies"]["shipped"]["fit"]
    assert sum(row["share"] for row in fit) == pytest.approx(1.0)
    assert all(row["mse"] is None or 0.0 <= row["mse"] < 0.5 for row in fit)


def test_bad_arguments_are_named():
    with pytest.raises(SystemExit, match="at least one --policy"):
        dd.main([])
    with pytest.raises(SystemExit, match="--teacher-options is not JSON"):
        dd.main(["--policy", "a=b", "--teacher-options", "{bad"])
    with pytest.raises(SystemExit, match="--episodes must be at least 1"):
        dd.main(["--policy", "a=b", "--episodes", "0"])
