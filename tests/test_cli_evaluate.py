"""``evaluate.py benchmark`` and ``evaluate.py paper`` end to end, on tiny inputs."""

from __future__ import annotations

import csv
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hev_thermal_env import load_cycle
from hev_thermal_env.evaluation import benchmark
from hev_thermal_env.evaluation.benchmark import BenchmarkProgress, expected_cost_s, run_benchmark
from hev_thermal_env.evaluation.executors import LocalExecutor
from hev_thermal_env.evaluation.results_table import COLUMNS

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "evaluate.py"), *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)


@pytest.fixture(scope="module")
def tiny_cycles(tmp_path_factory) -> list[str]:
    d = tmp_path_factory.mktemp("cycles")
    paths = []
    for name, start in (("hwfet", 0), ("beijing", 100)):
        cyc = load_cycle(name)
        path = d / f"{name}_tiny.csv"
        v = cyc.speed_mps[start:start + 121]
        path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
        paths.append(str(path))
    return paths


TEXT_OR_OPTIONAL = {"cycle", "scenario", "strategy", "family", "seeds", "reference", "frontier_note", "frontier_ratio",
                    "charge_sustaining", "score", "score_anchor_ratio", "score_note",  # no engine_only: no score
                    *(c for c in COLUMNS if "_ci_" in c)}


def test_benchmark_writes_every_file_and_column(tiny_cycles, tmp_path):
    out = tmp_path / "bench"
    r = run("benchmark", "--cycles", *tiny_cycles, "--strategies", "rule", "dp", "--scenarios", "paper",
            "--out", str(out), "--jobs", "1")
    assert r.returncode == 0, r.stderr
    assert "dp_thermal was added" in r.stdout  # the reference joins every benchmark, and the output says so
    for f in ("results.csv", "results.json", "results.md", "timings.json", "fuel_vs_optimum.png",
              "traces_hwfet_tiny_paper.png", "traces_beijing_tiny_paper.png"):
        assert (out / f).is_file() and (out / f).stat().st_size > 0, f
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 6 and [row["strategy"] for row in rows[:3]] == ["rule", "dp", "dp_thermal"]
    assert tuple(rows[0]) == COLUMNS
    for row in rows:
        for c in COLUMNS:
            if c not in TEXT_OR_OPTIONAL:
                assert np.isfinite(float(row[c])), (c, row[c])
        assert row["reference"].startswith("dp_thermal") and row["charge_sustaining"] in ("True", "False")
        if row["strategy"] == "dp":
            assert float(row["fuel_vs_thermal_blind_dp_pct"]) == pytest.approx(100.0)
        if row["strategy"] == "dp_thermal":
            assert float(row["fixed_price_ratio"]) == pytest.approx(1.0)
            if row["frontier_ratio"]:  # the optimum's own run lies on its frontier
                assert float(row["frontier_ratio"]) == pytest.approx(1.0, abs=0.01)
            else:  # a dp_thermal that publishes no frontier: no ratio, and the note says why
                assert "no frontier" in row["frontier_note"]
        if row["strategy"] == "rule":
            assert float(row["fuel_vs_thermal_blind_dp_pct"]) >= 100.0 - 1e-6
    data = json.loads((out / "results.json").read_text())
    assert data["columns"] == list(COLUMNS) and len(data["rows"]) == 6
    md = (out / "results.md").read_text()
    assert sum(line.startswith("| ") for line in md.splitlines()) == 7
    assert "| dp (thermal-blind) |" in md and "frontier ratio" in md and "J1711" in md
    assert "See docs/metrics.md." in md and (ROOT / "docs" / "metrics.md").is_file()


def test_a_failed_run_leaves_the_others_written_and_is_raised_after(tiny_cycles, tmp_path):
    out = tmp_path / "bench"
    with pytest.raises(ValueError) as info:  # no path of dp reaches SOC 0.95 within 120 s
        run_benchmark(out, cycles=tiny_cycles[:1], strategies=("rule", "dp"), jobs=1, progress=False,
                      options={"dp": {"soc_final": 0.95}})
    assert str(info.value).startswith(f"1 of 3 runs failed (the other runs are in {out}): hwfet_tiny/paper/dp: dp: ")
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert [row["strategy"] for row in rows] == ["rule", "dp_thermal"]
    assert float(rows[0]["frontier_ratio"]) >= 1.0 - 1e-3  # the reference ran: the other rows keep their ratios
    md = (out / "results.md").read_text()
    assert "Failed, left out: hwfet_tiny/paper/dp: dp: no feasible path to the final SOC 0.9500" in md
    assert (out / "fuel_vs_optimum.png").is_file() and (out / "traces_hwfet_tiny_paper.png").is_file()


@pytest.mark.full
def test_benchmark_parallel_equals_serial_byte_for_byte(tiny_cycles, tmp_path):
    kw = dict(cycles=tiny_cycles, strategies=("rule", "ecms", "dp"), scenarios=("paper", "hot"), progress=False,
              plots=False)
    run_benchmark(tmp_path / "serial", jobs=1, **kw)
    run_benchmark(tmp_path / "parallel", jobs=2, **kw)
    run_benchmark(tmp_path / "again", jobs=2, **kw)
    for f in ("results.csv", "results.json", "results.md"):
        a = (tmp_path / "serial" / f).read_bytes()
        assert a == (tmp_path / "parallel" / f).read_bytes(), f
        assert a == (tmp_path / "again" / f).read_bytes(), f


def _sigint_default() -> None:
    """In the child before it starts: SIGINT back to its default. A suite started in the background by a shell
    without job control runs with SIGINT ignored, a child inherits that, and Python then keeps it ignored (as a
    user's ``cmd &`` would want); these tests are about a terminal's Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("jobs", ["2", "1"])
def test_ctrl_c_in_the_benchmark_prints_one_line(tiny_cycles, tmp_path, jobs):
    """SIGINT while the runs are in progress (``--jobs 1``: in this process, its kernels compiling, the optimum
    solving): the workers stay quiet, the command says ``interrupted`` and exits 130."""
    env = {**os.environ, "HEV_THERMAL_ENV_CACHE_DIR": str(tmp_path / "cache")}  # no plan on disk: dp_thermal works
    err_path = tmp_path / "stderr.txt"
    with err_path.open("w") as err:
        proc = subprocess.Popen([sys.executable, str(ROOT / "evaluate.py"), "benchmark", "--cycles", tiny_cycles[0],
                                 "--strategies", "dp_thermal", "rule", "--jobs", jobs, "--no-plots",
                                 "--out", str(tmp_path / "out")], cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                                stderr=err, preexec_fn=_sigint_default)
        try:
            deadline = time.monotonic() + 120
            while "running" not in err_path.read_text(errors="replace") and time.monotonic() < deadline:
                time.sleep(0.2)
            time.sleep(2.0)  # the workers are starting or solving
            proc.send_signal(signal.SIGINT)
            assert proc.wait(timeout=60) == 130
        finally:
            proc.kill()
    lines = [ln for ln in re.split(r"[\r\n]+", err_path.read_text(errors="replace")) if ln.strip()]
    assert [ln for ln in lines if not ln.startswith("benchmark:")] == ["interrupted"]
    assert lines[-1] == "interrupted"


CTRL_C_IN_A_CALLBACK = """
import os, signal, sys

armed = False

def ctrl_c():
    if armed:  # SIGINT now: Python runs its handler at the next bytecode, still in here
        os.kill(os.getpid(), signal.SIGINT)

if sys.argv[1] == "compile":  # numba's callback from LLVM that records the machine code of a compiled function
    from numba.core import codegen
    recorded = codegen.CPUCodeLibrary._object_compiled_hook.__func__
    def interrupted(cls, ll_module, buf):
        ctrl_c()
        return recorded(cls, ll_module, buf)
    codegen.CPUCodeLibrary._object_compiled_hook = classmethod(interrupted)

from hev_thermal_env.cli.errors import run_program

class Finalized:
    def __del__(self):
        ctrl_c()

def plus_one(x):
    return x + 1

def body():
    global armed
    armed = True
    if sys.argv[1] == "compile":
        import numba
        numba.njit(cache=True)(plus_one)(1)
    else:
        Finalized()

sys.exit(run_program(body))
"""


@pytest.mark.parametrize("where", ["compile", "finalizer"])
def test_ctrl_c_inside_a_call_from_c_is_not_lost(tmp_path, where):
    """A Ctrl-C that Python handles inside a function called from C (numba's compiler callback, a ``__del__``), where
    a ``KeyboardInterrupt`` cannot propagate, still ends the program in one line with 130: it is neither lost (exit 0
    after the work) nor, in the compiler, leaves the machine code unrecorded for numba's cache write (exit 1)."""
    script = tmp_path / "ctrl_c.py"
    script.write_text(CTRL_C_IN_A_CALLBACK)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, str(script), where], capture_output=True, text=True, cwd=tmp_path, env=env,
                       timeout=120, preexec_fn=_sigint_default)
    assert (r.returncode, r.stderr) == (130, "interrupted\n")


def test_the_bar_names_the_run_in_progress_and_moves_during_it_in_this_process(monkeypatch, capsys):
    """With one job the runs go on in this process: the bar still names the run, counts its time and moves."""
    def slow_run(task):
        time.sleep(2.6)
        return {"strategy": task[2]}, {}

    monkeypatch.setattr(benchmark, "_run_one", slow_run)
    tasks = [("c", "paper", "dp_thermal", {}), ("c", "paper", "rule", {})]
    with LocalExecutor(1) as executor:
        results = benchmark._run_tasks(tasks, executor, True, {"c": ("tiny", 121)})
    assert [r[0]["strategy"] for r in results] == ["dp_thermal", "rule"]
    frames = [f for f in re.split(r"[\r\n]+", capsys.readouterr().err) if f.startswith("benchmark:")]
    during = [f for f in frames if "0/2 runs done; running tiny/paper/dp_thermal 00:02" in f]
    assert during, frames
    # dp_thermal weighs 7.5 s, rule 0.2 s: 2-2.6 s into the first run the work is 26-34 % done, about 5 s left
    percent, left = re.match(r"benchmark:\s*(\d+)%.*<(\d\d:\d\d)", during[-1]).groups()
    assert 20 <= int(percent) <= 40 and left in ("00:04", "00:05", "00:06"), during[-1]
    assert any("1/2 runs done; running tiny/paper/rule" in f for f in frames) and "2/2 runs done" in frames[-1]


def test_progress_names_the_runs_in_progress_and_weighs_them_by_cost():
    assert expected_cost_s("dp_thermal", 1000) > 100 * expected_cost_s("rule", 1000)
    assert expected_cost_s("dp_thermal", 2000) > 1.9 * expected_cost_s("dp_thermal", 1000)
    bar = BenchmarkProgress(["a", "b", "c"], [60.0, 1.0, 1.0], order=[0, 1, 2], slots=2, enabled=False)
    bar.show()
    assert bar.bar.postfix.startswith("0/3 runs done; running a 00:00, b 00:00")
    bar.finished(1)
    bar.show()
    assert "1/3 runs done; running a" in bar.bar.postfix and ", c " in bar.bar.postfix
    bar.finished(0)
    bar.finished(2)
    bar.show()
    assert bar.bar.postfix == "3/3 runs done"


def test_paper_report_quick_within_tolerances(tmp_path, tiny_cycles):
    out = tmp_path / "paper"
    r = run("paper", "--out", str(out), "--quick", "--cycles", "beijing")
    assert r.returncode == 0, r.stderr
    data = json.loads((out / "paper.json").read_text())
    t3 = data["table3"]
    verdicts = {v["name"]: v for v in data["verdicts"]}
    assert all(verdicts[k]["within"] for k in ("top_speed_off_kmh", "accel_off_s", "grade_off_kmh"))
    assert t3["top_speed_off_kmh"] == pytest.approx(89.0, rel=0.05)
    assert t3["accel_off_s"] == pytest.approx(16.4, rel=0.07)
    assert t3["grade_speed_off_kmh"] == pytest.approx(48.3, rel=0.07)
    assert t3["accel_50c_s"] > t3["accel_30c_s"] >= t3["accel_off_s"]
    assert data["fig4"]["pwm_leaves_zero_s"] == pytest.approx(30, abs=1)
    assert data["fig4"]["pwm_reaches_one_s"] == pytest.approx(130, abs=1)
    tc = data["thermal_cutoff"]
    assert tc["time_to_cutoff_simulated_s"] == pytest.approx(tc["time_to_cutoff_analytic_s"], rel=0.02)
    assert "beijing" in data["table2"]
    report = (out / "report.md").read_text()
    for png in ("fig4_heat_index.png", "thermal_time_to_cutoff.png", "fig_temperature_heat_index_beijing.png",
                "verdicts.png", "fig_table2_fuel.png", "fig_temperature_heat_index_udds.png"):
        assert (out / png).is_file() and png in report
    # the report opens with the verdicts: one per paper figure, a summary line, then the fuel levels
    sections = [ln for ln in report.splitlines() if ln.startswith("## ")]
    assert sections[:2] == ["## Verdicts", "## Absolute fuel levels against Table 2"]
    agr = data["agreement"]
    assert f"Agreement: {agr['within']} of {agr['total']} paper figures within tolerance" in report
    assert agr["total"] == len(data["verdicts"]) >= 19
    verdict_lines = [ln for ln in report.splitlines() if ln.endswith(("| within tolerance |", "| OUTSIDE tolerance |"))]
    assert len(verdict_lines) == agr["total"]
    assert {"accel_30c_delta_s", "accel_50c_delta_s", "udds_fuel_delta_l100"} <= {v["name"] for v in data["verdicts"]}
    assert {r["cycle"] for r in data["fuel_levels"]} == {"hwfet", "udds", "beijing"}



def test_the_results_name_each_learned_rows_track():
    """A learned row's track (docs/training.md, *Two tracks*): guided where its training imitates a strategy (the
    shipped policy imitates ecms_thermal), RL where it does not; classic rows have none."""
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.results_table import _track_lines

    shipped = get_strategy("ppo").describe()
    assert shipped["imitate"] == "ecms_thermal"
    rows = [{"strategy": "ppo", "strategy_settings": shipped},
            {"strategy": "ppo:runs/pure", "strategy_settings": {**shipped, "imitate": None}},
            {"strategy": "ecms", "strategy_settings": {"s": 2.9}},
            {"strategy": "ppo:runs/fam/s0", "family": "fam", "strategy_settings": shipped},
            {"strategy": "ppo:runs/fam/s1", "family": "fam", "strategy_settings": shipped}]
    (line,) = [x for x in _track_lines(rows) if x]
    assert "`ppo` guided (its training imitates `ecms_thermal`)" in line and "`ppo:runs/pure` RL" in line
    assert "`fam` guided" in line and "s0" not in line  # a family under its name, its members not one by one
    assert "ecms`" not in line
    assert _track_lines(rows[2:3]) == []
