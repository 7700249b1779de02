"""The learned-policy report (benchmarks/ppo_vs_dp_report.py) on the committed result file."""

import copy
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("ppo_vs_dp_report", ROOT / "benchmarks/ppo_vs_dp_report.py")
report = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(report)  # a script beside the benchmark, not a package module


@pytest.fixture(scope="module")
def data():
    return json.loads((ROOT / "benchmarks/results/ppo_vs_dp.json").read_text())


def _validation_ratios(data, name, leave_out=()):
    return [c["runs"][name]["frontier_ratio"] for c in data["cells"]
            if c["scenario"] == "paper" and c["family"] != "built-in" and c["cycle"] not in leave_out]


def test_selection_cycles_come_from_the_training_configs(data):
    selected = report.selection_cycles(data)
    assert selected == [f"validation_bus:{k}" for k in range(20, 30)]
    # none of them is a cell, so the unselected mean is the mean over every validation cell
    m = report.member_metrics(data["cells"], "ppo", selected)
    assert m["validation_mean_unselected"] == pytest.approx(np.mean(_validation_ratios(data, "ppo")))
    assert "none of them is a cell here" in report.selection_note(data)


def test_cells_selected_on_are_left_out_of_the_unselected_mean(data):
    d = copy.deepcopy(data)
    d["training"][0]["selection_cycles"] = ["validation_bus:0", "validation_bus:1"]
    selected = report.selection_cycles(d)
    assert selected[:2] == ["validation_bus:0", "validation_bus:1"]
    m = report.member_metrics(d["cells"], "ppo", selected)
    expected = np.mean(_validation_ratios(d, "ppo", leave_out=("validation_bus:0", "validation_bus:1")))
    assert m["validation_mean_unselected"] == pytest.approx(expected)
    assert m["validation_mean_unselected"] != pytest.approx(m["validation_mean"])
    assert "`validation_bus:0`, `validation_bus:1` are cells here" in report.selection_note(d)
