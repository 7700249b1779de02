"""A catalogue of bad inputs to every command: one clear line, a non-zero exit, no traceback, no partial output;
outputs that cannot be written are found before any work.

(The training command's own catalogue is in ``tests/test_train.py``.)
"""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import hev_thermal_env.evaluation.benchmark as bench
import hev_thermal_env.io as hev_io
from hev_thermal_env.cli import paper as cli_paper
from hev_thermal_env.cli import performance as cli_performance
from hev_thermal_env.cli import run as cli_run
from hev_thermal_env.cli.evaluate import main as evaluate_main
from hev_thermal_env.cli.train import main as train_main
from hev_thermal_env.io import atomic_write_json, atomic_write_text, check_output_path, check_writable_dir
from hev_thermal_env.training.loop import TrainingRun

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


# --- outputs that cannot be written: one line naming the directory, before any work ----------------------

def unwritable_dir() -> Path:
    """A directory that refuses new files even to root (sysfs), or skip."""
    d = Path("/sys")
    try:
        check_writable_dir(d)
    except OSError:
        return d
    pytest.skip("no directory here refuses new files")


class WorkStarted(Exception):
    pass


def _no_work(*args, **kwargs):
    raise WorkStarted("the work started before the output was checked")


@pytest.mark.parametrize("flag", ["--json", "--trace", "--plot"])
def test_run_output_in_an_unwritable_directory(flag, monkeypatch, capsys):
    monkeypatch.setattr(cli_run, "run_strategy", _no_work)
    target = unwritable_dir() / "hev" / ("r.png" if flag == "--plot" else "r.out")
    assert evaluate_main(["run", "--cycle", "hwfet", "--strategy", "dp", flag, str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert str(target.parent) in err and "not writable" in err


@pytest.mark.parametrize("command", ["paper", "benchmark", "train"])
def test_report_directories_that_cannot_be_written(command, monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(cli_paper, "build_report", _no_work)
    monkeypatch.setattr(bench, "_run_tasks", _no_work)
    monkeypatch.setattr(TrainingRun, "prepare", _no_work)
    (tmp_path / "file").write_text("x")
    for out, needle in ((unwritable_dir() / "out", "not writable"), (tmp_path / "file" / "out", "not a directory")):
        if command == "train":
            code = train_main(["--out", str(out), "--timesteps", "256", "--eval-cycles", "--no-progress"])
        else:
            code = evaluate_main([command, "--out", str(out), *(["--strategies", "rule"] * (command == "benchmark"))])
        assert code == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "Traceback" not in err
        assert needle in err and str(out.parent) in err, err
        assert not out.exists()


def test_read_only_file_system_is_one_line(monkeypatch, tmp_path, capsys):
    """Errno 30 (EROFS), as on a read-only mount: found by the probe, before the run."""
    def read_only(directory, name):
        raise OSError(errno.EROFS, "Read-only file system", str(directory))

    monkeypatch.setattr(hev_io, "_open_temp", read_only)
    monkeypatch.setattr(cli_run, "run_strategy", _no_work)
    assert evaluate_main(["run", "--cycle", "hwfet", "--strategy", "rule", "--json", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {tmp_path}: not writable (read-only file system)"


def test_write_errors_after_the_checks_are_one_line(monkeypatch, tmp_path, capsys):
    """An OSError while writing (the disk fills, the mount turns read-only) is still one line, naming the file."""
    def fails(path, data):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(cli_performance, "atomic_write_json", fails)
    assert evaluate_main(["performance", "--json", str(tmp_path / "p.json")]) == 2
    out = capsys.readouterr()
    assert out.err.strip() == f"error: {tmp_path / 'p.json'}: read-only file system"


# --- outputs get the user's permissions, and special files are never replaced -----------------------------

@pytest.mark.parametrize("mask", [0o022, 0o027, 0o002])
def test_outputs_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        for name, write in (("a.txt", lambda p: atomic_write_text(p, "x\n")),
                            ("b.json", lambda p: atomic_write_json(p, {"x": 1}))):
            write(tmp_path / name)
            assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~mask
    finally:
        os.umask(old)


def test_command_outputs_follow_the_umask(tmp_path):
    out = tmp_path / "perf.json"
    r = subprocess.run([sys.executable, str(ROOT / "evaluate.py"), "performance", "--json", str(out)],
                       capture_output=True, text=True, cwd=ROOT, timeout=300, preexec_fn=lambda: os.umask(0o002))
    assert r.returncode == 0, r.stderr
    assert stat.S_IMODE(out.stat().st_mode) == 0o664


def test_links_and_devices_are_written_through_not_replaced(tmp_path):
    (tmp_path / "real.json").write_text("old\n")
    (tmp_path / "link.json").symlink_to(tmp_path / "real.json")
    (tmp_path / "null").symlink_to(os.devnull)
    check_output_path(tmp_path / "link.json")
    check_output_path(tmp_path / "null")
    atomic_write_text(tmp_path / "link.json", "new\n")
    atomic_write_text(tmp_path / "null", "discarded\n")
    assert (tmp_path / "link.json").is_symlink() and (tmp_path / "real.json").read_text() == "new\n"
    assert (tmp_path / "null").is_symlink() and stat.S_ISCHR(os.stat(os.devnull).st_mode)
    assert not list(tmp_path.glob(".*.tmp"))
