"""The bad-input catalogue: every way a user can get the input wrong, across ``evaluate.py`` (every
subcommand), ``train.py`` and the Python API (``gym.make`` arguments, ``reset`` options, ``load_cycle``
on malformed CSVs, configs from YAML, ``simulate``, strategies).

Each command-line case runs the program in a fresh working directory holding the input files below and
must end with a non-zero exit status and exactly one line on stderr (``error: ...`` or, for usage
errors, ``PROG: error: ... (see --help)``), no traceback, and the directory exactly as it was: no output,
no run directory, no partial file. Each API case must raise the given exception type with a one-line
message naming the problem. Outputs that cannot be written, the umask and implausible (but valid)
cycle data follow the catalogue.
"""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import hev_thermal_env
import hev_thermal_env.evaluation.benchmark as bench
import hev_thermal_env.io as hev_io
from hev_thermal_env import Conditions, ConfigError, VehicleConfig, load_cycle, simulate
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cli import run as cli_performance
from hev_thermal_env.cli import run as cli_run
from hev_thermal_env.cli.evaluate import main as evaluate_main
from hev_thermal_env.cli.train import main as train_main
from hev_thermal_env.cycles import PLAUSIBLE_ACCEL_MAX_MPS2, PLAUSIBLE_SPEED_MAX_MPS, ImplausibleCycleWarning
from hev_thermal_env.io import atomic_write_json, atomic_write_text, check_output_path, check_writable_dir
from hev_thermal_env.training.loop import TrainingRun
from tools.paper import report as paper_report

ROOT = Path(__file__).resolve().parents[1]

# --- the input files every case can use (written into the case's working directory) ---------------------

BAD_CSV = {  # file -> (content, what the message must name besides the file)
    "empty.csv": ("", []),
    "header_only.csv": ("time_s,speed_mps\n", ["no data rows"]),
    "no_speed.csv": ("time_s,velocity\n0,0\n1,1\n", ["speed_mps"]),
    "nan.csv": ("time_s,speed_mps\n0,0\n1,nan\n2,1\n", ["data row 2"]),
    "negative.csv": ("time_s,speed_mps\n0,0\n1,-2\n2,1\n", ["data row 2", "negative"]),
    "backwards.csv": ("time_s,speed_mps\n0,0\n2,1\n1,1\n", ["data row 3"]),
    "uneven.csv": ("time_s,speed_mps\n0,0\n1,1\n3,1\n", ["data row 3"]),
    "text.csv": ("time_s,speed_mps\n0,0\n1,fast\n", ["data row 2", "'fast'"]),
    "missing_value.csv": ("time_s,speed_mps\n0,0\n1,\n", ["data row 2", "missing value"]),
    "duplicate.csv": ("time_s,speed_mps,speed_mps\n0,0,0\n1,1,1\n", ["duplicate column"]),
    "percent_grade.csv": ("time_s,speed_mps,grade\n0,0,4\n1,1,4\n", ["data row 1", "grade = 4.0"]),
    "one_row.csv": ("time_s,speed_mps\n0,0\n", ["at least 2 samples"]),
}
FILES = {
    **{name: content for name, (content, _) in BAD_CSV.items()},
    "file": "a file where a directory is expected",
    "result.json": '{"keep": true}\n',
    "bad.yaml": "glider: [1, 2\n",
    "negative_mass.yaml": "glider:\n  mass_kg: -3\n",
    "unknown_field.yaml": "glider:\n  mass_kgg: 3\n",
    "wrong_type.yaml": "glider:\n  mass_kg: heavy\n",
    "soc_window.yaml": "battery:\n  soc_min: 0.9\n  soc_max: 0.5\n",
    "empty.yaml": "",
    "hp_bad.yaml": "gamma: [\n",
}


@pytest.fixture
def workdir(tmp_path, monkeypatch) -> Path:
    for name, content in FILES.items():
        (tmp_path / name).write_text(content)
    (tmp_path / "latin1.csv").write_bytes("time_s,speed_mps\n0,0\n1,1 \xe9\n".encode("latin-1"))
    (tmp_path / "folder.csv").mkdir()
    (tmp_path / "no_model").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


def snapshot(d: Path) -> dict[str, tuple]:
    return {str(p.relative_to(d)): (p.is_dir(), p.read_bytes() if p.is_file() else None) for p in d.rglob("*")}


# --- the catalogue: command lines ------------------------------------------------------------------------

RUN = ["run", "--cycle", "hwfet", "--strategy", "rule"]
TRAIN = ["--out", "run", "--no-progress", "--timesteps", "256", "--eval-cycles"]

CLI_CASES = [  # (id, program, argv, texts the one line must contain)
    # evaluate.py: usage
    ("no-subcommand", "evaluate", [], ["required"]),
    ("unknown-subcommand", "evaluate", ["frobnicate"], ["invalid choice"]),
    ("run-no-args", "evaluate", ["run"], ["required"]),
    ("run-no-strategy", "evaluate", ["run", "--cycle", "hwfet"], ["--strategy"]),
    ("run-seed-text", "evaluate", [*RUN, "--seed", "abc"], ["--seed", "invalid int"]),
    ("run-dp-points-text", "evaluate", [*RUN[:-1], "dp", "--dp-soc-points", "many"], ["invalid int"]),
    ("benchmark-no-strategies", "evaluate", ["benchmark", "--strategies"], ["expected at least one"]),
    ("benchmark-jobs-text", "evaluate", ["benchmark", "--jobs", "abc"], ["--jobs", "invalid int"]),
    ("performance-coolant", "evaluate", ["performance", "--coolant", "tepid"], ["invalid choice", "tepid"]),
    ("performance-temp-text", "evaluate", ["performance", "--initial-motor-temp-c", "hot"], ["invalid float"]),
    # evaluate.py run
    ("run-unknown-strategy", "evaluate", [*RUN[:-1], "magic"], ["unknown strategy 'magic'", "ecms"]),
    ("run-unknown-cycle", "evaluate", ["run", "--cycle", "atlantis", "--strategy", "rule", "--json", "result.json"],
     ["unknown cycle 'atlantis'", "hwfet"]),
    ("run-unknown-scenario", "evaluate", [*RUN, "--scenario", "arctic"], ["unknown scenario 'arctic'", "paper"]),
    ("run-negative-seed", "evaluate", [*RUN, "--scenario", "random", "--seed", "-1"], ["--seed", "-1"]),
    ("run-dp-points-one", "evaluate", [*RUN[:-1], "dp", "--dp-soc-points", "1"], ["--dp-soc-points", "at least 2"]),
    ("run-dp-flag-for-rule", "evaluate", [*RUN, "--dp-actions", "5"], ["apply to dp", "'rule'"]),
    ("run-option-no-value", "evaluate", [*RUN, "--option", "foo"], ["--option 'foo'", "KEY=VALUE"]),
    ("run-option-unknown", "evaluate", [*RUN, "--option", "foo=1"], ["unknown option(s) ['foo']", "hi_soc"]),
    ("run-option-wrong-type", "evaluate", [*RUN[:-1], "aecms", "--option", "s0=abc"], ["'aecms'", "'abc'"]),
    ("run-plot-not-png", "evaluate", [*RUN, "--plot", "r.txt"], ["--plot", ".png"]),
    ("run-json-under-a-file", "evaluate", [*RUN, "--json", "file/r.json"], ["file", "not a directory"]),
    ("run-trace-is-a-directory", "evaluate", [*RUN, "--trace", "."], ["is a directory"]),
    ("run-ppo-missing-model", "evaluate", [*RUN[:-1], "ppo:nowhere.zip"], ["nowhere.zip", "not found"]),
    ("run-ppo-empty-directory", "evaluate", [*RUN[:-1], "ppo:no_model"], ["no model in directory"]),
    *[(f"run-csv-{name}", "evaluate", ["run", "--cycle", name, "--strategy", "rule"], [name, *needles])
      for name, (_, needles) in BAD_CSV.items()],
    ("run-csv-not-utf8", "evaluate", ["run", "--cycle", "latin1.csv", "--strategy", "rule"], ["latin1.csv", "UTF-8"]),
    ("run-csv-is-a-folder", "evaluate", ["run", "--cycle", "folder.csv", "--strategy", "rule"],
     ["folder.csv", "is a directory"]),
    # evaluate.py benchmark: every problem found before the first run
    ("benchmark-unknown-cycle", "evaluate", ["benchmark", "--cycles", "nowhere", "--out", "out"], ["unknown cycle"]),
    ("benchmark-bad-csv", "evaluate", ["benchmark", "--cycles", "nan.csv", "--strategies", "rule", "--out", "out"],
     ["nan.csv", "data row 2"]),
    ("benchmark-unknown-strategy", "evaluate", ["benchmark", "--strategies", "magic", "--out", "out"],
     ["unknown strategy 'magic'"]),
    ("benchmark-missing-model", "evaluate", ["benchmark", "--cycles", "hwfet", "--strategies", "rule", "ppo:gone.zip",
                                             "--out", "out"], ["gone.zip", "not found"]),
    ("benchmark-unknown-scenario", "evaluate", ["benchmark", "--scenarios", "paper", "arctic", "--out", "out"],
     ["unknown scenario 'arctic'"]),
    ("benchmark-jobs-zero", "evaluate", ["benchmark", "--jobs", "0", "--out", "out"], ["--jobs", "at least 1"]),
    ("benchmark-out-is-a-file", "evaluate", ["benchmark", "--strategies", "rule", "--out", "file"],
     ["file", "not a directory"]),
    ("benchmark-family-no-name", "evaluate", ["benchmark", "--family", "runs/a,runs/b", "--out", "out"],
     ["--family 'runs/a,runs/b'", "NAME=PATH"]),
    ("benchmark-family-unknown-path", "evaluate", ["benchmark", "--family", "fam=no_model,gone", "--out", "out"],
     ["--family fam", "gone not found"]),
    ("benchmark-family-one-seed", "evaluate", ["benchmark", "--family", "fam=result.json", "--out", "out"],
     ["--family fam", "at least 2 runs, got 1", "ppo:result.json"]),
    ("benchmark-family-no-runs-inside", "evaluate", ["benchmark", "--family", "fam=no_model", "--out", "out"],
     ["--family fam", "no_model", "neither a train.py run nor a directory of runs"]),
    ("benchmark-family-named-like-a-strategy", "evaluate", ["benchmark", "--family", "ecms=result.json,file",
                                                            "--out", "out"], ["'ecms'", "taken"]),
    ("benchmark-family-not-a-model", "evaluate", ["benchmark", "--cycles", "hwfet", "--strategies", "rule",
                                                  "--family", "fam=result.json,file", "--out", "out"], ["result.json"]),
    # evaluate.py paper
    ("paper-unknown-cycle", "evaluate", ["paper", "--cycles", "atlantis", "--out", "out"], ["unknown cycle"]),
    ("paper-out-under-a-file", "evaluate", ["paper", "--out", "file/x"], ["file", "not a directory"]),
    # evaluate.py performance: values and vehicle configs
    ("performance-temp-too-high", "evaluate", ["performance", "--initial-motor-temp-c", "500"],
     ["initial_motor_temp_c", "500"]),
    ("performance-ambient-too-low", "evaluate", ["performance", "--ambient-temp-c", "-100"], ["ambient_temp_c"]),
    ("performance-temp-nan", "evaluate", ["performance", "--initial-motor-temp-c", "nan"], ["not finite"]),
    ("performance-json-is-a-directory", "evaluate", ["performance", "--json", "."], ["is a directory"]),
    ("config-not-yaml", "evaluate", ["performance", "--config", "bad.yaml"], ["bad.yaml", "not valid YAML"]),
    ("config-missing", "evaluate", ["performance", "--config", "missing.yaml"], ["missing.yaml", "no such config"]),
    ("config-out-of-range", "evaluate", ["performance", "--config", "negative_mass.yaml"], ["mass_kg", "-3"]),
    ("config-unknown-field", "evaluate", ["performance", "--config", "unknown_field.yaml"], ["'mass_kgg'", "known"]),
    ("config-wrong-type", "evaluate", ["performance", "--config", "wrong_type.yaml"], ["mass_kg", "'heavy'"]),
    ("config-inconsistent", "evaluate", ["performance", "--config", "soc_window.yaml"], ["soc_window.yaml", "soc_min"]),
    ("config-empty", "evaluate", ["performance", "--config", "empty.yaml"], ["empty.yaml", "empty"]),
    # train.py
    ("train-no-out", "train", ["--no-progress"], ["--out DIR is required"]),
    ("train-timesteps-text", "train", [*TRAIN, "--timesteps", "abc"], ["--timesteps", "invalid int"]),
    ("train-unknown-algo", "train", [*TRAIN, "--algo", "dqn"], ["unknown algorithm 'dqn'"]),
    ("train-unknown-cycle", "train", [*TRAIN, "--cycles", "hwfet", "nope"], ["unknown cycle 'nope'"]),
    ("train-bad-csv", "train", [*TRAIN, "--cycles", "negative.csv"], ["negative.csv", "negative speed"]),
    ("train-unknown-eval-cycle", "train", [*TRAIN, "nope"], ["unknown cycle 'nope'"]),
    ("train-unknown-scenario", "train", [*TRAIN, "--scenario", "sahara"], ["unknown scenario 'sahara'"]),
    ("train-unknown-eval-scenario", "train", [*TRAIN, "--eval-scenarios", "arctic"], ["unknown scenario 'arctic'"]),
    ("train-timesteps-zero", "train", [*TRAIN, "--timesteps", "0"], ["total_timesteps", "at least 1"]),
    ("train-n-envs-zero", "train", [*TRAIN, "--n-envs", "0"], ["n_envs", "at least 1"]),
    ("train-negative-seed", "train", [*TRAIN, "--seed", "-1"], ["seed", "-1"]),
    ("train-eval-freq-negative", "train", [*TRAIN, "--eval-freq", "-1"], ["eval.freq", "-1"]),
    ("train-checkpoint-freq-zero", "train", [*TRAIN, "--checkpoint-freq", "0"], ["checkpoint_freq", "0"]),
    ("train-hyperparams-missing", "train", [*TRAIN, "--hyperparams", "missing.yaml"], ["missing.yaml", "not found"]),
    ("train-hyperparams-not-yaml", "train", [*TRAIN, "--hyperparams", "hp_bad.yaml"],
     ["hp_bad.yaml", "not valid YAML"]),
    ("train-hyperparams-empty", "train", [*TRAIN, "--hyperparams", "empty.yaml"], ["empty.yaml", "mapping"]),
    ("train-hp-no-value", "train", [*TRAIN, "--hp", "gamma"], ["expected key=value"]),
    ("train-hp-typo", "train", [*TRAIN, "--hp", "gama=0.9"], ["'gama'", "did you mean 'gamma'"]),
    ("train-hp-not-a-number", "train", [*TRAIN, "--hp", "gamma=abc"], ["gamma", "'abc'", "expected a number"]),
    ("train-hp-not-an-integer", "train", [*TRAIN, "--hp", "n_steps=6.5"], ["n_steps", "6.5", "expected an integer"]),
    ("train-hp-nested-typo", "train", [*TRAIN, "--hp", "policy_kwargs.netarch=[8]"], ["did you mean 'net_arch'"]),
    ("train-hp-normalize-typo", "train", [*TRAIN, "--hp", "normalize.clipobs=5"], ["did you mean 'clip_obs'"]),
    ("train-hp-env-typo", "train", [*TRAIN, "--hp", "env.scenaro=hot"], ["did you mean 'scenario'"]),
    ("train-hp-seed", "train", [*TRAIN, "--hp", "seed=4"], ["'seed'", "--seed"]),
    ("train-hp-activation", "train", [*TRAIN, "--hp", "policy_kwargs.activation_fn=sigmoid"], ["'sigmoid'"]),
    ("train-hp-schedule", "train", [*TRAIN, "--hp", "learning_rate=lin_x"], ["'lin_x'", "lin_3e-4"]),
    ("train-hp-n-steps-zero", "train", [*TRAIN, "--hp", "n_steps=0"], ["n_steps=0", "at least 2"]),
    ("train-hp-batch-size", "train", [*TRAIN, "--hp", "batch_size=-3"], ["batch_size", "-3"]),
    ("train-resume-missing", "train", ["--resume", "nowhere"], ["nowhere", "not found"]),
    ("train-resume-not-a-run", "train", ["--resume", "no_model"], ["not a train.py run directory"]),
    ("train-resume-with-settings", "train", ["--resume", "no_model", "--seed", "4"], ["drop --seed"]),
]


@pytest.mark.parametrize("program, argv, needles", [c[1:] for c in CLI_CASES], ids=[c[0] for c in CLI_CASES])
def test_command_line_catalogue(program, argv, needles, workdir, capsys):
    before = snapshot(workdir)
    main = evaluate_main if program == "evaluate" else train_main
    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse: usage errors
        code = exc.code
    captured = capsys.readouterr()
    assert code not in (0, None), captured.out
    lines = [ln for ln in captured.err.splitlines() if ln.strip()]
    assert len(lines) == 1, captured.err
    assert "Traceback" not in captured.err and "error: " in lines[0], lines[0]
    for text in needles:
        assert text in lines[0], (text, lines[0])
    assert snapshot(workdir) == before, "the failed command left something behind"


def test_the_catalogue_covers_every_program_and_subcommand():
    assert len(CLI_CASES) + len(API_CASES) + len(BAD_CSV) >= 40
    firsts = {(c[1], c[2][0] if c[1] == "evaluate" and c[2] else "") for c in CLI_CASES}
    for sub in ("run", "benchmark", "paper", "performance"):
        assert ("evaluate", sub) in firsts, sub
    assert any(c[1] == "train" for c in CLI_CASES)


@pytest.mark.parametrize("script, argv, needle", [
    ("evaluate.py", ["run", "--cycle", "atlantis", "--strategy", "rule", "--json", "r.json"], "unknown cycle"),
    ("evaluate.py", ["benchmark", "--jobs", "abc"], "invalid int value: 'abc'"),
    ("train.py", ["--hp", "gama=0.9", "--out", "run"], "did you mean 'gamma'"),
])
def test_the_scripts_fail_in_one_line(script, argv, needle, tmp_path):
    """The real programs, as a user starts them: exit status 2, one line, nothing created."""
    r = subprocess.run([sys.executable, str(ROOT / script), *argv], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and needle in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not list(tmp_path.iterdir())


# --- the catalogue: the Python API -----------------------------------------------------------------------

def _env(**kwargs) -> gym.Env:
    return gym.make("HevThermal-v2", **kwargs)


def _reset(**options):
    return _env().reset(seed=0, options=options)


def _step(action) -> None:
    env = _env().unwrapped
    env.reset(seed=0)
    env.step(action)


API_CASES: list[tuple[str, Callable[[], object], type[Exception], list[str]]] = [
    ("make-unknown-cycle", lambda: _env(cycle="atlantis"), ValueError, ["unknown cycle 'atlantis'"]),
    ("make-cycle-type", lambda: _env(cycle=3), TypeError, ["cycle", "int"]),
    ("make-no-cycles", lambda: _env(cycle=[]), ValueError, ["list of cycles is empty"]),
    ("make-unknown-scenario", lambda: _env(scenario="arctic"), ValueError, ["unknown scenario 'arctic'"]),
    ("make-preview", lambda: _env(preview_s=-1), ValueError, ["preview_s", "-1"]),
    ("make-reward-typo", lambda: _env(reward={"fuel_weigth": 1.0}), ConfigError, ["'fuel_weigth'", "fuel_weight"]),
    ("make-reward-type", lambda: _env(reward={"soc_deviation_weight": "x"}), ConfigError, ["soc_deviation_weight"]),
    ("make-render-mode", lambda: _env(render_mode="ascii"), ValueError, ["render_mode", "'ascii'"]),
    ("make-config-type", lambda: _env(config="paper_bus"), TypeError, ["config", "VehicleConfig"]),
    ("make-conditions-type", lambda: _env(conditions={"ambient_temp_c": 3}), TypeError, ["conditions"]),
    ("make-info-keys", lambda: _env(info_keys=("action",)), ValueError, ["info_keys", "'action'"]),
    ("make-unknown-argument", lambda: _env(colour="red"), TypeError, ["colour"]),
    ("reset-unknown-option", lambda: _reset(ambient=30.0), ValueError, ["'ambient'", "ambient_temp_c"]),
    ("reset-coolant", lambda: _reset(coolant="cold"), ValueError, ["coolant", "'cold'"]),
    ("reset-start", lambda: _reset(start_s=10**9), ValueError, ["start_s", "764"]),
    ("reset-soc", lambda: _reset(initial_soc=2.0), ConfigError, ["initial_soc", "2.0"]),
    ("reset-temperature-text", lambda: _reset(ambient_temp_c="hot"), ValueError, ["ambient_temp_c", "'hot'"]),
    ("reset-unknown-cycle", lambda: _reset(cycle="atlantis"), ValueError, ["unknown cycle 'atlantis'"]),
    ("step-nan", lambda: _step(np.array([np.nan], np.float32)), ValueError, ["finite"]),
    ("step-shape", lambda: _step(np.zeros(2, np.float32)), ValueError, ["shape (1,)"]),
    ("step-before-reset", lambda: _env().unwrapped.step(np.zeros(1)), RuntimeError, ["reset()"]),
    ("vector-num-envs", lambda: hev_thermal_env.HevThermalVectorEnv(0), ValueError, ["num_envs"]),
    ("load-cycle-type", lambda: load_cycle(None), TypeError, ["NoneType"]),
    ("load-cycle-latin1", lambda: load_cycle("latin1.csv"), ValueError, ["latin1.csv", "UTF-8"]),
    ("load-cycle-folder", lambda: load_cycle("folder.csv"), ValueError, ["folder.csv", "is a directory"]),
    ("yaml-not-yaml", lambda: VehicleConfig.from_yaml("bad.yaml"), ConfigError, ["bad.yaml", "not valid YAML"]),
    ("yaml-missing", lambda: VehicleConfig.from_yaml("missing.yaml"), ConfigError, ["missing.yaml"]),
    ("yaml-unknown-field", lambda: VehicleConfig.from_yaml("unknown_field.yaml"), ConfigError, ["'mass_kgg'"]),
    ("yaml-wrong-type", lambda: VehicleConfig.from_yaml("wrong_type.yaml"), ConfigError, ["mass_kg", "'heavy'"]),
    ("conditions-coolant", lambda: Conditions(coolant="tepid"), ConfigError, ["coolant", "'tepid'"]),
    ("simulate-split-nan", lambda: simulate("udds", split=np.nan), ValueError, ["split", "NaN"]),
    ("simulate-split-length", lambda: simulate("udds", split=np.zeros(7)), ValueError, ["one value per step"]),
    ("simulate-split-text", lambda: simulate("udds", split="half"), ValueError, ["split", "'half'"]),
    ("simulate-split-returns-nan", lambda: simulate("udds", split=lambda k, s: float("nan")), ValueError,
     ["split returned nan at step 0"]),
    ("simulate-config-type", lambda: simulate("udds", config="bus"), TypeError, ["config", "str"]),
    ("simulate-conditions-type", lambda: simulate("udds", conditions="hot"), TypeError, ["conditions", "str"]),
    ("strategy-unknown", lambda: get_strategy("magic"), ValueError, ["unknown strategy 'magic'", "dp"]),
    ("strategy-unknown-option", lambda: get_strategy("ecms", s0=1.0), ValueError, ["'s0'", "k_soc"]),
]


@pytest.mark.parametrize("call, error, needles", [c[1:] for c in API_CASES], ids=[c[0] for c in API_CASES])
def test_python_api_catalogue(call, error, needles, workdir):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium's own warnings (e.g. on an unknown render mode)
        with pytest.raises(error) as info:
            call()
    message = str(info.value)
    assert "\n" not in message, message
    for text in needles:
        assert text in message, (text, message)


@pytest.mark.parametrize("name", list(BAD_CSV))
def test_load_cycle_on_malformed_csv(name, workdir):
    with pytest.raises(ValueError) as info:
        load_cycle(name)
    message = str(info.value)
    assert "\n" not in message and f"cycle file '{name}'" in message
    for text in BAD_CSV[name][1]:
        assert text in message, (text, message)


# --- implausible but valid cycle data: a warning, not an error ------------------------------------------

def kmh_cycle(path: Path) -> Path:
    """A bus cycle written in km/h under a speed_mps header (peaks at 60 "m/s", steps of 4 per second)."""
    speeds = [min(4 * t, 60) for t in range(30)] + [max(60 - 4 * t, 0) for t in range(16)]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{v}\n" for t, v in enumerate(speeds)))
    return path


def test_implausible_cycle_data_warns_naming_row_and_value(tmp_path):
    path = kmh_cycle(tmp_path / "kmh.csv")
    with pytest.warns(ImplausibleCycleWarning) as record:
        cycle = load_cycle(path)
    messages = [str(w.message) for w in record]
    assert len(messages) == 2 and cycle.max_speed_kmh == pytest.approx(216.0)
    assert f"cycle file '{path}': data row 10 (line 11): speed_mps = 36 is beyond a bus's range" in messages[0]
    assert f"above {PLAUSIBLE_SPEED_MAX_MPS:g} m/s" in messages[0] and "km/h values" in messages[0]
    assert "data row 2 (line 3): acceleration +4 m/s²" in messages[1]
    assert f"above {PLAUSIBLE_ACCEL_MAX_MPS2:g} m/s²" in messages[1]
    with pytest.warns(ImplausibleCycleWarning, match="index 1: acceleration -5 m/s²"):
        hev_thermal_env.cycle_from_arrays([5.0, 0.0, 0.0])


def test_plausible_and_built_in_cycles_do_not_warn(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in hev_thermal_env.list_cycles():  # us06 and wltc_3b are faster than a bus: not checked
            load_cycle(name)
        load_cycle(load_cycle("beijing").to_csv(tmp_path / "route.csv"))
        hev_thermal_env.cycle_from_arrays([0.0, 1.0, 3.0, 5.0])


def test_implausible_cycle_data_is_one_warning_line_per_finding_in_the_commands(tmp_path):
    path = kmh_cycle(tmp_path / "kmh.csv")
    r = subprocess.run([sys.executable, str(ROOT / "evaluate.py"), "run", "--cycle", str(path), "--strategy", "rule"],
                       capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 2 and all(ln.startswith("warning: cycle file ") for ln in lines), r.stderr
    assert "data row 10 (line 11): speed_mps = 36" in lines[0] and "rule on kmh" in r.stdout


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
    monkeypatch.setattr(paper_report, "build_report", _no_work)
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
