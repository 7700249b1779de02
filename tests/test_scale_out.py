"""Scaling out on Ray: the benchmark matrix as Ray tasks (byte-identical files, a killed worker's cell run
again, an unreachable cluster, Ray not installed) and the workshop's sweeps through Ray Tune (``python -m
tools.sweep``: end to end, interrupted and resumed, best trial exported). One local Ray runtime (2 CPUs) is shared
by the module."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from hev_thermal_env import load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cli.evaluate import main as evaluate_main
from hev_thermal_env.evaluation.benchmark import run_benchmark
from hev_thermal_env.evaluation.executors import ExecutorError, split_address
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.stats import iqm, iqm_ci
from tools.sweep.cli import main as sweep_main
from tools.sweep.report import TrialRecord, creation_order, write_report
from tools.sweep.trial import check_space, encode_choice, trial_overrides

ROOT = Path(__file__).resolve().parents[1]

#: One worker runs this module and the README's Ray command (tests/test_readme.py), one after the other: a killed
#: worker below is found by its process title, which any Ray runtime of the machine gives its cells.
pytestmark = pytest.mark.xdist_group("ray")
RESULT_FILES = ("results.csv", "results.json", "results.md")
TINY_HP = ["n_steps=64", "batch_size=128", "n_epochs=2", "init.episodes=1", "init.epochs=2"]
SPACE = "learning_rate: {loguniform: [1.0e-4, 1.0e-3]}\npolicy_kwargs.net_arch: {choice: [[16, 16], [8]]}\n"


@pytest.fixture(scope="module")
def ray_runtime():
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="warning")
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def tiny_cycles(tmp_path_factory) -> list[str]:
    d = tmp_path_factory.mktemp("cycles")
    paths = []
    for name, start in (("hwfet", 0), ("beijing", 100)):
        v = load_cycle(name).speed_mps[start : start + 121]
        path = d / f"{name}_tiny.csv"
        path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
        paths.append(str(path))
    return paths


def assert_same_results(a: Path, b: Path) -> None:
    for f in RESULT_FILES:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f


def one_line(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in text, text
    return lines[0]


# --- the benchmark matrix on Ray ----------------------------------------------------------------------


@pytest.mark.full
def test_ray_matrix_is_byte_identical_to_local(ray_runtime, tiny_cycles, tmp_path, capsys):
    common = [
        "benchmark",
        "--cycles",
        *tiny_cycles,
        "--strategies",
        "rule",
        "ecms",
        "dp",
        "--scenarios",
        "paper",
        "hot",
        "--no-plots",
    ]
    assert evaluate_main([*common, "--out", str(tmp_path / "ray"), "--executor", "ray"]) == 0
    assert evaluate_main([*common, "--out", str(tmp_path / "local"), "--jobs", "1"]) == 0
    assert "16 runs" in capsys.readouterr().out  # dp_thermal, the reference, added
    assert_same_results(tmp_path / "ray", tmp_path / "local")
    rows = json.loads((tmp_path / "ray" / "results.json").read_text())["rows"]
    assert len(rows) == 16 and all(np.isfinite(r["fuel_corrected_l_per_100km"]) for r in rows)


def running_cell_pids() -> list[int]:
    """Ray workers of this machine executing a benchmark cell (their process title is ``ray::_run_one``)."""
    pids = []
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                if (p / "cmdline").read_bytes().startswith(b"ray::_run_one"):
                    pids.append(int(p.name))
            except OSError:
                continue
    return pids


@pytest.mark.full
def test_a_killed_worker_does_not_lose_the_matrix(ray_runtime, tiny_cycles, tmp_path):
    kw = dict(cycles=tiny_cycles, strategies=("dp", "ecms", "rule"), scenarios=("paper",), progress=False, plots=False)
    killed: list[int] = []

    def kill_first_cell():
        deadline = time.monotonic() + 120
        while not killed and time.monotonic() < deadline:
            for pid in running_cell_pids():
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                break
            time.sleep(0.005)

    killer = threading.Thread(target=kill_first_cell)
    killer.start()
    run_benchmark(tmp_path / "ray", executor="ray", **kw)
    killer.join()
    assert killed, "no running cell was seen"
    assert (
        not Path(f"/proc/{killed[0]}").exists()
        or b"ray::_run_one" not in Path(f"/proc/{killed[0]}/cmdline").read_bytes()
    )
    run_benchmark(tmp_path / "local", jobs=1, **kw)
    assert_same_results(tmp_path / "ray", tmp_path / "local")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_address_is_one_line_and_fast(tiny_cycles, tmp_path):
    address = f"127.0.0.1:{free_port()}"
    t0 = time.monotonic()
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "evaluate.py"),
            "benchmark",
            "--cycles",
            tiny_cycles[0],
            "--strategies",
            "rule",
            "--out",
            str(tmp_path / "out"),
            "--executor",
            "ray",
            "--address",
            address,
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    assert time.monotonic() - t0 < 30
    assert r.returncode != 0
    assert address in one_line(r.stderr) and "ray start --head" in r.stderr
    assert not (tmp_path / "out" / "results.csv").exists()


def test_address_forms_and_address_without_ray_executor(tmp_path, capsys):
    assert split_address("10.1.2.3:6380") == ("10.1.2.3", 6380)
    assert split_address("head") == ("head", 6379)
    assert split_address("ray://head") == ("head", 10001)
    with pytest.raises(ExecutorError, match="port 'x'"):
        split_address("head:x")
    assert evaluate_main(["benchmark", "--strategies", "rule", "--out", str(tmp_path), "--address", "h:1"]) == 2
    assert "--address needs --executor ray" in one_line(capsys.readouterr().err)


def test_without_ray_local_works_and_ray_says_how_to_install(monkeypatch, tiny_cycles, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # "import ray" now fails as if it were not installed
    run_benchmark(tmp_path / "local", cycles=tiny_cycles[:1], strategies=("rule",), jobs=1, progress=False, plots=False)
    assert (tmp_path / "local" / "results.csv").is_file()
    capsys.readouterr()  # the local run's own notices (a plan solved afresh is announced on stderr)
    args = ["benchmark", "--cycles", tiny_cycles[0], "--strategies", "rule", "--out", str(tmp_path / "r")]
    assert evaluate_main([*args, "--executor", "ray"]) == 2
    line = one_line(capsys.readouterr().err)
    assert "Ray" in line and 'pip install "hev-thermal-env[ray]"' in line
    assert sweep_main(["--out", str(tmp_path / "sweep")]) == 2
    assert 'pip install "hev-thermal-env[ray]"' in one_line(capsys.readouterr().err)
    assert not (tmp_path / "r").exists() and not (tmp_path / "sweep").exists()


# --- sweeps -------------------------------------------------------------------------------------------


def test_search_space_and_seed_statistics(tmp_path):
    space = {
        "learning_rate": {"loguniform": [1e-4, 1e-3]},
        "policy_kwargs.net_arch": {"choice": [[16, 16], [8]]},
        "n_epochs": {"int": [2, 4]},
        "ent_coef": 0.01,
    }
    check_space(space)
    sampled = {"learning_rate": 2e-4, "policy_kwargs.net_arch": encode_choice([16, 16]), "n_epochs": 3}
    assert trial_overrides(space, sampled) == {
        "ent_coef": 0.01,
        "learning_rate": 2e-4,
        "policy_kwargs.net_arch": [16, 16],
        "n_epochs": 3,
    }
    for bad, message in (
        ({"gamma": {"unifrom": [0.9, 0.99]}}, "did you mean 'uniform'"),
        ({"gamma": {"uniform": [0.99, 0.9]}}, "low < high"),
        ({"learning_rate": {"loguniform": [0, 1e-3]}}, "positive"),
        ({"n_epochs": {"choice": []}}, "non-empty"),
    ):
        with pytest.raises(ValueError, match=message):
            check_space(bad)
    assert iqm([1, 2, 3, 4]) == pytest.approx(2.5)
    assert iqm([0, 10, 11, 12, 13, 100]) == pytest.approx(11.5)
    low, high = iqm_ci([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    assert low < iqm([1, 2, 3, 4, 5, 6, 7, 8]) < high and (low, high) == iqm_ci([1, 2, 3, 4, 5, 6, 7, 8])
    assert iqm_ci([3.0]) == (None, None)


def test_sweep_report_ranks_configurations_by_the_iqm_of_their_seeds(tmp_path):
    """The sweep's tables and figure from trial records alone (no Ray): the best configuration by IQM, its best seed."""
    space = {"learning_rate": {"loguniform": [1e-4, 1e-3]}, "gamma": 0.97}

    def trial(n: int, config: str, lr: float, seed: int, status: str, returns: list[float]) -> TrialRecord:
        curve = [(256 * (k + 1), r) for k, r in enumerate(returns)]
        return TrialRecord(
            f"t{n}",
            config,
            {"learning_rate": lr},
            seed,
            status,
            curve[-1][0],
            returns[-1],
            max(returns),
            30.0 + n,
            curve,
            None,
            tmp_path / f"t{n}",
        )

    trials = [
        trial(0, "c0", 1e-4, 0, "finished", [-900.0, -850.0]),
        trial(1, "c0", 1e-4, 1, "stopped", [-950.0]),
        trial(2, "c1", 5e-4, 0, "finished", [-880.0, -800.0]),
        trial(3, "c1", 5e-4, 1, "finished", [-870, -810.0]),
    ]
    report = write_report(tmp_path, trials, {"space": space}, complete=False)
    assert [c.config_id for c in report.configs] == ["c1", "c0"] and report.best.trial_id == "t2"
    assert {p.name for p in tmp_path.iterdir() if p.is_file()} == {
        "sweep_trials.csv",
        "sweep_configs.csv",
        "sweep_configs.md",
        "sweep_configs.json",
        "sweep.png",
    }
    rows = list(csv.DictReader((tmp_path / "sweep_trials.csv").open()))
    assert [r["learning_rate"] for r in rows] == ["0.0001", "0.0001", "0.0005", "0.0005"]
    md = (tmp_path / "sweep_configs.md").read_text()
    assert "Best trial: t2 (c1, seed 0" in md and "--resume" in md
    assert (tmp_path / "sweep.png").stat().st_size > 10_000


def test_a_fixed_space_is_a_seed_grid_and_a_searched_one_goes_to_optuna():
    from ray.tune.schedulers import ASHAScheduler, MedianStoppingRule
    from ray.tune.search import Repeater
    from ray.tune.search.optuna import OptunaSearch

    from tools.sweep.study import _scheduler, _search, build_sweep, check_settings, total_trials

    train = dict(timesteps=1024, n_envs=2, eval_freq=256)
    fixed = build_sweep("ppo", space={"gamma": 0.97}, seeds=3, train=train)
    space, search, samples = _search(fixed)
    assert search is None and samples == 1 and space == {"__trial_index__": {"grid_search": [0, 1, 2]}}
    assert total_trials(fixed) == 3 and isinstance(_scheduler(fixed, check_settings(fixed)), ASHAScheduler)
    searched = build_sweep("ppo", samples=4, seeds=2, scheduler="median", train=train)
    space, search, samples = _search(searched)
    assert isinstance(search, Repeater) and isinstance(search.searcher, OptunaSearch) and samples == 8
    assert set(space) == {"learning_rate", "gamma", "gae_lambda", "clip_range", "n_epochs"}
    assert isinstance(_scheduler(searched, check_settings(searched)), MedianStoppingRule)


def test_sweep_bad_input_is_one_line(tmp_path, capsys):
    (tmp_path / "space.yaml").write_text("gama: {uniform: [0.9, 0.99]}\n")
    base = ["--out", str(tmp_path / "s"), "--no-progress", "--timesteps", "256", "--n-envs", "2"]
    for args, needle in (
        (["--space", str(tmp_path / "space.yaml")], "did you mean 'gamma'"),
        (["--hp", "max_grad_norm=big"], "max_grad_norm"),
        (["--hp", "n_epochs=4"], "also in the search space"),
        (["--eval-cycles", "nowhere"], "unknown cycle"),
        (["--scheduler", "hyperband"], "--scheduler"),
        (["--seeds", "0"], "--seeds"),
    ):
        assert sweep_main([*base, *args]) == 2, args
        assert needle in one_line(capsys.readouterr().err), args
    assert sweep_main(["--resume", str(tmp_path)]) == 2
    assert "not a sweep directory" in one_line(capsys.readouterr().err)
    assert not (tmp_path / "s").exists()


def interrupt_after_checkpoints(sweep_dir: Path) -> threading.Thread:
    """SIGUSR1 to this process (Tune's "stop and save") once Tune has recorded two results of a trial, each
    with a checkpoint."""

    def watch():
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            logs = sweep_dir.glob("tune/trial_*/result.json")
            if any(len(p.read_text().splitlines()) >= 2 for p in logs):
                os.kill(os.getpid(), signal.SIGUSR1)
                return
            time.sleep(0.05)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


def trial_results(trial_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (trial_dir / "result.json").read_text().splitlines() if line.strip()]


@pytest.mark.full
def test_sweep_end_to_end_interrupted_and_resumed(ray_runtime, tiny_cycles, tmp_path, capsys):
    out = tmp_path / "sweep"
    (tmp_path / "space.yaml").write_text(SPACE)
    args = [
        "--out",
        str(out),
        "--space",
        str(tmp_path / "space.yaml"),
        "--samples",
        "1",
        "--seeds",
        "2",
        "--timesteps",
        "3072",
        "--n-envs",
        "4",
        "--eval-freq",
        "256",
        "--cycles",
        "hwfet",
        "--eval-cycles",
        tiny_cycles[1],
        "--no-progress",
        "--hp",
        *TINY_HP,
    ]
    watcher = interrupt_after_checkpoints(out)
    assert sweep_main(args) == 130
    watcher.join()
    assert f"--resume {out}" in capsys.readouterr().err
    trial_dirs = sorted(out.glob("tune/trial_*"))
    assert len(trial_dirs) == 2
    before = {d.name: len(trial_results(d)) if (d / "result.json").is_file() else 0 for d in trial_dirs}

    assert sweep_main(["--resume", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "2 trials" in printed and f"ppo:{out / 'best_policy'}" in printed
    rows = list(csv.DictReader((out / "sweep_trials.csv").open()))
    assert len(rows) == 2 and {r["seed"] for r in rows} == {"0", "1"}
    assert len({(r["learning_rate"], r["policy_kwargs.net_arch"]) for r in rows}) == 1  # one configuration
    resumed = 0
    for r, d in zip(sorted(rows, key=lambda r: r["trial_id"]), trial_dirs):
        assert r["status"] in ("finished", "stopped") and int(r["timesteps"]) <= 3072
        assert r["status"] == "stopped" or int(r["timesteps"]) == 3072
        assert Path(r["checkpoint"]).is_dir() and (Path(r["checkpoint"]) / "config.yaml").is_file()
        assert (d / "run" / "config.yaml").is_file() and list(d.glob("checkpoint_*"))
        results = trial_results(d)
        assert results[-1]["timesteps"] == int(r["timesteps"]) and len(results) > before[d.name]
        resumed += max(x["resumed_from_timesteps"] for x in results) > 0
    assert resumed >= 1, "no trial continued from a checkpoint"
    (config,) = list(csv.DictReader((out / "sweep_configs.csv").open()))
    scores = [float(r["eval_return_g"]) for r in rows]
    assert config["seeds"] == "2" and min(scores) <= float(config["eval_return_g_iqm"]) <= max(scores)
    assert float(config["ci95_low"]) <= float(config["eval_return_g_iqm"]) <= float(config["ci95_high"])
    assert "95 % CI" in (out / "sweep_configs.md").read_text()
    assert (out / "sweep.png").stat().st_size > 10_000
    strategy = get_strategy(f"ppo:{out / 'best_policy'}")
    cycle = load_cycle(tiny_cycles[0])
    res = run_strategy(strategy, cycle, "paper")
    assert res.summary["duration_s"] == cycle.n_steps and np.all(np.abs(res.trace["u"]) <= 1.0)
    assert "Best trial of a sweep" in (out / "best_policy" / "README.md").read_text()


def test_configurations_are_numbered_in_the_order_their_trials_were_created():
    """A restored Tune experiment lists its trials in another order than the live one: the report numbers the
    configurations by creation (the number that starts a trial's experiment tag), so a resumed sweep keeps c0, c1..."""
    from types import SimpleNamespace

    listed = [SimpleNamespace(trial_id=i, experiment_tag=tag) for i, tag in
              [("e", "1_batch_size=512"), ("a", "4_x=1"), ("b", "10_x=2"), ("c", "3_x=3"), ("d", "2_x=4"),
               ("f", "")]]
    assert [t.trial_id for t in creation_order(listed)] == ["e", "d", "c", "a", "b", "f"]


# --- tuning with rl-zoo3 (docs/scaling-out.md) --------------------------------------------------------------

#: The documented tuning command's budgets and log folder, shrunk for the test: flag -> value.
TINY_TUNING = {"--n-trials": "2", "--n-timesteps": "600", "--n-evaluations": "1", "--eval-episodes": "1"}


@pytest.mark.full
def test_the_documented_rl_zoo3_tuning_command_writes_its_report(tmp_path):
    """The rl-zoo3 command of docs/scaling-out.md, run from the checkout's root as written but for its budgets and
    log folder: two Optuna trials, the best trial's parameters printed and every trial's in the report."""
    page = (ROOT / "docs" / "scaling-out.md").read_text()
    blocks = [b for b in page.split("```text\n")[1:] if b.startswith("python -m rl_zoo3.train")]
    assert len(blocks) == 1, "docs/scaling-out.md: no (or more than one) rl-zoo3 tuning command"
    words = blocks[0].split("```")[0].replace("\\\n", " ").split()
    assert "-optimize" in words and "--log-folder" in words
    for flag, value in {**TINY_TUNING, "--log-folder": str(tmp_path / "tuning")}.items():
        words[words.index(flag) + 1] = value
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, *words[1:]], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "Best trial:" in done.stdout and "Params:" in done.stdout
    (report,) = (tmp_path / "tuning" / "sac").glob("report_HevThermal-v2_2-trials-600-tpe-median_*.csv")
    assert report.with_suffix(".pkl").is_file()
    rows = list(csv.DictReader(report.open()))
    assert len(rows) == 2 and all(r["state"] == "COMPLETE" and np.isfinite(float(r["value"])) for r in rows)
    assert all(r["params_learning_rate"] and r["user_attrs_gamma"] for r in rows)
