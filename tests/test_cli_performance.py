"""``evaluate.py performance``: end to end on the default bus, and its bad inputs."""

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


def test_performance_hot_start_slower():
    from hev_thermal_env.cli.performance import main  # noqa: F401  (import check)
    r30 = run("performance", "--initial-motor-temp-c", "30", "--coolant", "off", "--json", "/dev/stdout")
    r50 = run("performance", "--initial-motor-temp-c", "50", "--coolant", "off", "--json", "/dev/stdout")
    assert r30.returncode == 0 and r50.returncode == 0


@pytest.mark.parametrize("args, message", [
    (["performance", "--coolant", "lukewarm"], "invalid choice"),
    (["performance", "--initial-motor-temp-c", "hot"], "invalid float"),
    (["performance", "--config", "missing.yaml"], "no such config file"),
    (["nonsense"], "invalid choice"),
])
def test_performance_bad_input(args, message):
    r = run(*args)
    assert r.returncode != 0
    assert message in r.stderr
    assert "Traceback" not in r.stderr


def test_performance_output_is_a_directory(tmp_path):
    r = run("performance", "--json", str(tmp_path))
    assert r.returncode == 2
    assert "is a directory" in r.stderr and "Traceback" not in r.stderr


def test_performance_bad_config_names_field(tmp_path):
    cfg = tmp_path / "bus.yaml"
    cfg.write_text("battery:\n  soc_min: 0.9\n  soc_max: 0.5\n")
    r = run("performance", "--config", str(cfg))
    assert r.returncode == 2
    assert "soc_min" in r.stderr and "bus.yaml" in r.stderr and "Traceback" not in r.stderr
