"""A catalogue of bad inputs to every command: one clear line, a non-zero exit, no traceback, no partial output.

(The training command's own catalogue is in ``tests/test_train.py``.)
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def evaluate(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "evaluate.py"), *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)


def assert_clean_failure(r: subprocess.CompletedProcess, *needles: str) -> None:
    assert r.returncode != 0, r.stdout
    assert "Traceback" not in r.stderr, r.stderr
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert lines, "no message"
    text = r.stderr.lower()
    for n in needles:
        assert n.lower() in text, (n, r.stderr)


@pytest.fixture(scope="module")
def csv_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("bad")
    (d / "empty.csv").write_text("")
    (d / "header_only.csv").write_text("time_s,speed_mps\n")
    (d / "no_speed.csv").write_text("time_s,velocity\n0,0\n1,1\n")
    (d / "nan.csv").write_text("time_s,speed_mps\n0,0\n1,nan\n2,1\n")
    (d / "negative.csv").write_text("time_s,speed_mps\n0,0\n1,-2\n2,1\n")
    (d / "backwards.csv").write_text("time_s,speed_mps\n0,0\n2,1\n1,1\n")
    (d / "uneven.csv").write_text("time_s,speed_mps\n0,0\n1,1\n3,1\n")
    (d / "text.csv").write_text("time_s,speed_mps\n0,0\n1,fast\n")
    (d / "bad.yaml").write_text("glider: [1, 2\n")
    (d / "bad_field.yaml").write_text("glider:\n  mass_kg: -3\n")
    return d


# --- missing and unknown arguments ------------------------------------------------------------------

@pytest.mark.parametrize("args, needles", [
    ([], ["required"]),
    (["frobnicate"], ["invalid choice"]),
    (["run"], ["required"]),
    (["run", "--cycle", "hwfet"], ["--strategy"]),
    (["run", "--cycle", "hwfet", "--strategy", "magic"], ["unknown strategy", "ecms"]),
    (["run", "--cycle", "atlantis", "--strategy", "rule"], ["unknown cycle", "hwfet"]),
    (["run", "--cycle", "hwfet", "--strategy", "rule", "--scenario", "arctic"], ["unknown scenario", "paper"]),
    (["run", "--cycle", "hwfet", "--strategy", "dp", "--dp-soc-points", "many"], ["invalid int"]),
    (["benchmark", "--strategies"], ["expected at least one"]),
    (["paper", "--cycles", "atlantis"], ["unknown cycle"]),
    (["performance", "--coolant", "tepid"], ["invalid choice"]),
])
def test_missing_or_unknown_arguments(args, needles):
    assert_clean_failure(evaluate(*args), *needles)


# --- malformed files -------------------------------------------------------------------------------

@pytest.mark.parametrize("name, needles", [
    ("empty.csv", ["empty.csv"]),
    ("header_only.csv", ["header_only.csv"]),
    ("no_speed.csv", ["no_speed.csv", "speed_mps"]),
    ("nan.csv", ["nan.csv", "row"]),
    ("negative.csv", ["negative.csv", "row", "negative"]),
    ("backwards.csv", ["backwards.csv", "row"]),
    ("uneven.csv", ["uneven.csv", "row"]),
    ("text.csv", ["text.csv", "row"]),
])
def test_malformed_cycle_csv(csv_dir, name, needles):
    assert_clean_failure(evaluate("run", "--cycle", str(csv_dir / name), "--strategy", "rule"), *needles)
    assert_clean_failure(evaluate("benchmark", "--cycles", str(csv_dir / name), "--strategies", "rule",
                                  "--out", str(csv_dir / "never")), name)
    assert not (csv_dir / "never").exists()


@pytest.mark.parametrize("name, needles", [("bad.yaml", ["bad.yaml", "yaml"]),
                                           ("bad_field.yaml", ["bad_field.yaml", "mass_kg"]),
                                           ("missing.yaml", ["missing.yaml", "no such config file"])])
def test_malformed_vehicle_config(csv_dir, name, needles):
    assert_clean_failure(evaluate("performance", "--config", str(csv_dir / name)), *needles)


# --- out-of-range values ------------------------------------------------------------------------------

@pytest.mark.parametrize("args, needles", [
    (["performance", "--initial-motor-temp-c", "500"], ["initial_motor_temp_c", "500"]),
    (["performance", "--ambient-temp-c", "-100"], ["ambient_temp_c"]),
    (["benchmark", "--jobs", "-1"], ["--jobs"]),
])
def test_out_of_range_values(args, needles):
    assert_clean_failure(evaluate(*args), *needles)


# --- outputs: never a partial file over an existing one ------------------------------------------------

def test_failed_run_leaves_existing_outputs_alone(tmp_path):
    js = tmp_path / "result.json"
    js.write_text('{"keep": true}\n')
    r = evaluate("run", "--cycle", "atlantis", "--strategy", "rule", "--json", str(js))
    assert_clean_failure(r, "unknown cycle")
    assert js.read_text() == '{"keep": true}\n'


def test_output_path_problems(tmp_path):
    (tmp_path / "file").write_text("x")
    assert_clean_failure(evaluate("run", "--cycle", "hwfet", "--strategy", "rule", "--json",
                                  str(tmp_path / "file" / "r.json")), "not a directory")
    assert_clean_failure(evaluate("run", "--cycle", "hwfet", "--strategy", "rule", "--json", str(tmp_path)),
                         "directory")
    assert_clean_failure(evaluate("benchmark", "--strategies", "rule", "--cycles", "hwfet", "--out",
                                  str(tmp_path / "file")), "not a directory")
    assert_clean_failure(evaluate("paper", "--out", str(tmp_path / "file")), "not a directory")
