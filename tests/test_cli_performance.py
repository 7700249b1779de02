"""``evaluate.py performance``: end to end on the default bus (its bad inputs: ``tests/test_bad_inputs.py``)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "evaluate.py"), *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)


def test_performance_writes_json_and_table(tmp_path):
    out = tmp_path / "perf.json"
    r = run("performance", "--no-thermal", "--json", str(out))
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    assert set(data) == {"top_speed_kmh", "accel_0_60_s", "grade_4pct_speed_kmh"}
    assert data["top_speed_kmh"] == pytest.approx(89.0, rel=0.05)
    assert "top speed" in r.stdout and "km/h" in r.stdout


def test_performance_hot_start_slower(tmp_path):
    """In this process (the command's own process is the test above's): a hotter start accelerates no faster."""
    from hev_thermal_env.cli.evaluate import main

    times = []
    for temp in ("30", "50"):
        out = tmp_path / f"perf_{temp}.json"
        assert main(["performance", "--initial-motor-temp-c", temp, "--coolant", "off", "--json", str(out)]) == 0
        times.append(json.loads(out.read_text())["accel_0_60_s"])
    assert times[1] >= times[0]


@pytest.mark.parametrize("args, row, paper_0_60", [
    (["--no-thermal"], "paper (thermal off)", "16.4"),
    (["--initial-motor-temp-c", "30", "--coolant", "off"], "paper (30 °C start, coolant closed)", "16.8"),
    (["--initial-motor-temp-c", "50", "--coolant", "off"], "paper (50 °C start, coolant closed)", "17.1"),
    (["--initial-motor-temp-c", "40"], "paper (no row for these settings)", "-"),
])
def test_performance_compares_with_the_papers_row_for_its_settings(args, row, paper_0_60, capsys):
    from hev_thermal_env.cli.evaluate import main

    assert main(["performance", *args]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].rstrip().endswith(row)
    (accel,) = [ln for ln in lines if ln.strip().startswith("0-60 km/h")]
    assert accel.split()[-1] == paper_0_60
