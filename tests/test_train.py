"""``train.py`` and the ``ppo`` strategy: a tiny training run end to end, the shipped policy,
interruption (SIGINT, SIGKILL) and resume, and one-line errors on bad input."""

from __future__ import annotations

import csv
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import evaluate
import train
from hev_thermal_env import load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.agents.policy_files import load_policy
from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR, PPOStrategy
from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.training.config import load_run_config
from hev_thermal_env.training.envs import PolicyEvaluator
from hev_thermal_env.training.hyperparams import apply_overrides, parse_overrides
from hev_thermal_env.training.loop import TrainingRun

ROOT = Path(__file__).resolve().parents[1]



# a small but complete PPO: 4 envs x 64 steps = 256 env-steps per rollout
TINY_HP = ["n_steps=64", "batch_size=128", "n_epochs=2", "policy_kwargs.net_arch=[16,16]", "init.episodes=1",
           "init.epochs=2"]


def tiny_cycle_csv(path: Path, name: str = "beijing", start: int = 100, n: int = 91) -> str:
    v = load_cycle(name).speed_mps[start:start + n]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return str(path)


def train_args(out: Path, timesteps: int, *extra: str, hp: tuple[str, ...] = ()) -> list[str]:
    return ["--algo", "ppo", "--cycles", "random_bus", "bus_launch", "--scenario", "random_service", "--timesteps",
            str(timesteps),
            "--n-envs", "4", "--seed", "3", "--out", str(out), "--no-progress", "--quiet",
            "--hp", *TINY_HP, *hp, *extra]


def one_line_error(captured: str) -> str:
    lines = [ln for ln in captured.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, captured
    assert "Traceback" not in captured
    return lines[0]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("train")
    cyc = tiny_cycle_csv(d / "short.csv")
    out = d / "run"
    code = train.main(train_args(out, 1024, "--eval-cycles", cyc, "--eval-freq", "512", "--checkpoint-freq", "512",
                                 hp=("eval.final_cycles=[validation_bus:0..1]",)))
    assert code == 0
    return out


# --- the run directory ------------------------------------------------------------------------------

def test_smoke_run_writes_the_zoo_layout(tiny_run):
    for f in ("model.zip", "best_model.zip", "vecnormalize.pkl", "best_vecnormalize.pkl", "config.yaml",
              "command.txt", "evaluations.csv", "validation.csv", "training_curve.png"):
        assert (tiny_run / f).is_file() and (tiny_run / f).stat().st_size > 0, f
    assert any((tiny_run / "tb").rglob("events.out.tfevents.*"))
    assert sorted(p.name for p in (tiny_run / "checkpoints").glob("*.zip")) == ["ckpt_1024_steps.zip",
                                                                                "ckpt_512_steps.zip"]
    cfg = load_run_config(tiny_run)
    assert cfg["algo"] == "ppo" and cfg["seed"] == 3 and cfg["total_timesteps"] == 1024 and cfg["n_envs"] == 4
    assert cfg["env"]["cycles"] == ["random_bus", "bus_launch"] and cfg["env"]["scenario"] == "random_service"
    assert cfg["env"]["preview_s"] == 10 and cfg["env"]["observation_size"] == 21
    assert cfg["hyperparams"]["n_steps"] == 64 and cfg["hyperparams"]["policy_kwargs"]["net_arch"] == [16, 16]
    assert {"torch", "stable_baselines3", "gymnasium", "hev_thermal_env"} <= set(cfg["versions"])
    res = cfg["result"]
    assert res["finished"] and res["timesteps_done"] == 1024 and 0.0 < res["env_share"] < 1.0
    assert "--timesteps 1024" in (tiny_run / "command.txt").read_text()
    rows = list(csv.DictReader((tiny_run / "evaluations.csv").open()))
    assert [(int(r["timesteps"]), r["scenario"]) for r in rows] == [(512, "paper"), (512, "full_bus"),
                                                                    (1024, "paper"), (1024, "full_bus")]
    assert all(math.isfinite(float(r["fuel_corrected_l_per_100km"])) for r in rows)
    # the final model is kept (ppo.yaml's eval.selection: final); the corrected fuel relative to ECMS on the same run
    # is still scored (ECMS computed once, kept in the config)
    assert cfg["eval"]["selection"] == "final" and len(res["selection_reference"]) == 2 + 4
    for r in rows:
        ref = res["selection_reference"][f"{r['cycle']} / {r['scenario']}"]
        assert float(r["fuel_ratio"]) == pytest.approx(float(r["fuel_corrected_l_per_100km"]) / ref, rel=1e-5)
    assert res["best_eval"]["selection"] == "final" and res["best_eval"]["timesteps"] == 1024
    val = list(csv.DictReader((tiny_run / "validation.csv").open()))
    assert [(r["model"], r["cycle"], r["scenario"]) for r in val[:4]] == [
        ("best_model.zip", "validation_bus:0", "paper"), ("best_model.zip", "validation_bus:1", "paper"),
        ("best_model.zip", "validation_bus:0", "full_bus"), ("best_model.zip", "validation_bus:1", "full_bus")]
    assert len(val) == 8 and set(res["validation"]["models"]) == {"best_model.zip", "model.zip"}
    assert res["validation"]["runs"] == 4


def test_resuming_a_finished_run_does_nothing(tiny_run, capsys):
    before = (tiny_run / "model.zip").read_bytes()
    assert train.main(["--resume", str(tiny_run), "--no-progress"]) == 0
    assert "already finished" in capsys.readouterr().out
    assert (tiny_run / "model.zip").read_bytes() == before


def test_trained_run_evaluates_through_the_registry(tiny_run):
    short = load_cycle("us06")
    for strategy in (get_strategy(f"ppo:{tiny_run}"), get_strategy("ppo", path=tiny_run / "best_model.zip"),
                     get_strategy(f"ppo:{tiny_run / 'checkpoints' / 'ckpt_512_steps.zip'}")):
        res = run_strategy(strategy, short, "paper")
        assert res.summary["duration_s"] == short.n_steps
        assert np.all(np.abs(res.trace["u"]) <= 1.0)
    assert get_strategy(f"ppo:{tiny_run}").label == f"ppo:{tiny_run}"


def test_training_evaluation_matches_run_strategy(tiny_run):
    """The batched evaluation during training reports what run_strategy measures for the same policy."""
    policy = load_policy(tiny_run)
    cfg = load_run_config(tiny_run)
    (ev,) = PolicyEvaluator(cfg["env"], ["us06"], ["paper"]).run(policy.act)
    ref = run_strategy(PPOStrategy(tiny_run), "us06", "paper").summary
    assert ev["fuel_corrected_l_per_100km"] == pytest.approx(ref["fuel_corrected_l_per_100km"], rel=1e-9)
    assert ev["delta_soc"] == pytest.approx(ref["delta_soc"], abs=1e-12)


def test_strategy_normalises_observations_without_updating_them(tiny_run):
    strategy = PPOStrategy(tiny_run)
    mean = strategy.policy.stats.obs_rms.mean.copy()
    run_strategy(strategy, "us06", "paper")
    np.testing.assert_array_equal(strategy.policy.stats.obs_rms.mean, mean)


def test_sac_trains_checkpoints_its_replay_buffer_and_plays(tmp_path):
    out = tmp_path / "sac"
    assert train.main(["--algo", "sac", "--timesteps", "600", "--n-envs", "2", "--out", str(out), "--no-progress",
                       "--quiet", "--eval-cycles", "--checkpoint-freq", "300",
                       "--hp", "learning_starts=200", "buffer_size=1000", "batch_size=32",
                       "policy_kwargs.net_arch=[16,16]"]) == 0
    assert (out / "checkpoints" / "ckpt_600_steps_replay_buffer.pkl").is_file()
    assert not (out / "checkpoints" / "ckpt_300_steps_replay_buffer.pkl").exists()  # only the newest is kept
    strategy = get_strategy(f"ppo:{out}")
    assert strategy.describe()["algo"] == "sac"
    assert run_strategy(strategy, "us06", "paper").summary["duration_s"] == load_cycle("us06").n_steps
    # exported as the shipped policy is (the sweep's best trial too): without the actor's and critic's optimizer
    # state, a smaller file that drives the same
    from hev_thermal_env.training import export_policy

    exported = export_policy(out / "model.zip", tmp_path / "exported")
    assert (exported / "model.zip").stat().st_size < (out / "model.zip").stat().st_size
    again = run_strategy(get_strategy(f"ppo:{exported}"), "us06", "paper").trace["motor_share"]
    np.testing.assert_array_equal(again, run_strategy(strategy, "us06", "paper").trace["motor_share"])


def test_eval_cycles_none_trains_without_evaluation(tmp_path):
    out = tmp_path / "run"
    assert train.main(train_args(out, 256, "--eval-cycles", "none")) == 0
    cfg = load_run_config(out)
    assert cfg["eval"]["cycles"] == [] and cfg["result"]["timesteps_done"] == 256
    assert not (out / "evaluations.csv").exists() and (out / "model.zip").is_file()


# --- the shipped policy -----------------------------------------------------------------------------

def test_shipped_policy_loads_and_drives_a_short_cycle(tmp_path):
    files = {p.name: p.stat().st_size for p in DEFAULT_POLICY_DIR.iterdir()}
    assert {"model.zip", "vecnormalize.pkl", "config.yaml", "README.md"} <= set(files)
    assert files["model.zip"] < 200_000
    strategy = get_strategy("ppo")
    assert strategy.describe()["algo"] == "ppo"
    res = run_strategy(strategy, tiny_cycle_csv(tmp_path / "c.csv", "hwfet", 200, 121), "paper")
    assert res.summary["cutoff_s"] == 0.0 and abs(res.summary["delta_soc"]) < 0.05


# --- hyperparameter overrides -----------------------------------------------------------------------

def test_hp_overrides_yaml_dict_and_dotted_keys():
    o = parse_overrides(["gamma=0.99", "learning_rate=lin_1e-4", "policy_kwargs={net_arch: [64, 64], "
                         "activation_fn: relu}", "env.reward.soc_deviation_weight=1.5", "normalize.clip_obs=5"])
    assert o["gamma"] == 0.99 and o["learning_rate"] == "lin_1e-4"
    assert o["policy_kwargs"] == {"net_arch": [64, 64], "activation_fn": "relu"}
    hp = apply_overrides({"gamma": 0.97, "policy_kwargs": {"log_std_init": -1.0}, "env": {"scenario": "paper"}}, o)
    assert hp["policy_kwargs"] == {"log_std_init": -1.0, "net_arch": [64, 64], "activation_fn": "relu"}
    assert hp["env"] == {"scenario": "paper", "reward": {"soc_deviation_weight": 1.5}}
    assert parse_overrides(["policy_kwargs={net_arch: [32], activation_fn: tanh}"])["policy_kwargs"] == {
        "net_arch": [32], "activation_fn": "tanh"}


def test_repeated_hp_flags_all_apply():
    """``--hp a=1 --hp b=2`` keeps both: a later flag adds to the earlier ones, never silently replaces them."""
    from hev_thermal_env.cli.train import build_parser
    args = build_parser().parse_args(["--hp", "gamma=0.99", "n_epochs=3", "--hp", "policy_kwargs.net_arch=[256,256]"])
    assert parse_overrides(args.hp) == {"gamma": 0.99, "n_epochs": 3, "policy_kwargs.net_arch": [256, 256]}


def test_env_soc_offset_reaches_the_training_env_but_never_the_evaluation():
    from hev_thermal_env.training import build_config
    from hev_thermal_env.training.envs import env_kwargs

    cfg = build_config("ppo", overrides={"env.soc_offset": 0.05})
    assert env_kwargs(cfg["env"])["soc_offset"] == 0.05 and env_kwargs(cfg["env"], for_eval=True)["soc_offset"] == 0
    assert env_kwargs(build_config("ppo")["env"])["soc_offset"] == 0.03  # ppo.yaml's
    assert env_kwargs(build_config("sac")["env"])["soc_offset"] == 0.0  # the env's default
    with pytest.raises(ValueError, match=r"env.soc_offset: expected a number in \[0, 0.2\] \(SOC\), got 0.5"):
        build_config("ppo", overrides={"env.soc_offset": 0.5})


# --- interruption and resume ------------------------------------------------------------------------

@pytest.mark.full
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["sigint", "sigkill"])
def test_interrupted_training_resumes_to_the_total(tmp_path, sig):
    """Ctrl-C (SIGINT) once training has started: a checkpoint and one stderr line after the progress bars, exit
    status 130; SIGKILL: the last complete checkpoint. Either resumes to the total."""
    out = tmp_path / "run"
    total = 30_720  # 120 rollouts of 256 env-steps
    args = [sys.executable, str(ROOT / "train.py"),
            *[a for a in train_args(out, total, "--eval-cycles", "--checkpoint-freq", "1024") if a != "--no-progress"]]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    with open(tmp_path / "stderr.txt", "w") as stderr:
        proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=stderr, text=True, env=env)
        deadline = time.monotonic() + 60
        while not list((out / "checkpoints").glob("ckpt_*_steps.zip")):
            assert proc.poll() is None, (tmp_path / "stderr.txt").read_text()
            assert time.monotonic() < deadline
            time.sleep(0.02)
        proc.send_signal(sig)
        proc.wait(timeout=60)
    err = (tmp_path / "stderr.txt").read_text()
    if sig == signal.SIGINT:
        assert proc.returncode == 130, err
        lines = [ln for ln in re.split(r"[\r\n]", err) if ln.strip()]
        bars = [i for i, ln in enumerate(lines) if "episode/s]" in ln]  # the imitation's progress bar
        assert bars and len(lines) == bars[-1] + 2, err
        assert lines[-1].startswith("interrupted: training stopped by SIGINT") and "--resume" in lines[-1]
        cfg = load_run_config(out)
        stopped = cfg["result"]["timesteps_done"]
        assert (out / "checkpoints" / f"ckpt_{stopped}_steps.zip").is_file()
        assert stopped < total and stopped % 256 == 0
    else:
        assert proc.returncode == -signal.SIGKILL
    assert not (out / "model.zip").exists()
    r = subprocess.run([sys.executable, str(ROOT / "train.py"), "--resume", str(out), "--no-progress", "--quiet"],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "resuming from ckpt_" in r.stdout
    cfg = load_run_config(out)
    assert cfg["result"]["finished"] and cfg["result"]["timesteps_done"] == total
    assert (out / "model.zip").is_file() and (out / "checkpoints" / f"ckpt_{total}_steps.zip").is_file()
    assert (out / "vecnormalize.pkl").is_file()  # the resumed model's statistics
    assert "--resume" in (out / "command.txt").read_text().splitlines()[-1]


def test_a_start_that_fails_after_validation_leaves_no_run_directory(tmp_path, monkeypatch, capsys):
    """Whatever fails while the env and the model are built, the run directory is not created."""
    def fail(self, resume_from=None):
        raise ValueError("the model cannot be built")

    monkeypatch.setattr(TrainingRun, "prepare", fail)
    out = tmp_path / "run"
    assert train.main(train_args(out, 256, "--eval-cycles")) == 2
    assert "cannot be built" in one_line_error(capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.full
def test_train_with_the_progress_bar_as_a_user_runs_it(tmp_path):
    """The README's command line, progress bar on (SB3 draws it with tqdm and rich)."""
    out = tmp_path / "run"
    args = [a for a in train_args(out, 256, "--eval-cycles") if a not in ("--no-progress", "--quiet")]
    r = subprocess.run([sys.executable, str(ROOT / "train.py"), *args], cwd=ROOT, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert (out / "model.zip").is_file()


def test_train_refuses_to_overwrite_a_run(tiny_run, capsys):
    assert train.main(train_args(tiny_run, 512)) == 2
    assert "--resume" in one_line_error(capsys.readouterr().err)


def _evaluate_ppo(spec: str, capsys) -> str:
    pytest.importorskip("hev_thermal_env.cli.run")
    assert evaluate.main(["run", "--cycle", "us06", "--strategy", spec]) == 2
    return one_line_error(capsys.readouterr().err)


def test_evaluate_reports_a_missing_model(tmp_path, capsys):
    assert "not found" in _evaluate_ppo(f"ppo:{tmp_path / 'nope.zip'}", capsys)
    assert "no model in directory" in _evaluate_ppo(f"ppo:{tmp_path}", capsys)


def test_evaluate_reports_corrupt_files(tiny_run, tmp_path, capsys):
    bad = tmp_path / "bad"
    shutil.copytree(tiny_run, bad)
    (bad / "model.zip").write_bytes(b"this is not a zip")
    assert "is not a model zip" in _evaluate_ppo(f"ppo:{bad}", capsys)
    shutil.copy(tiny_run / "model.zip", bad / "model.zip")
    (bad / "vecnormalize.pkl").write_bytes(b"\x80\x04garbage")
    assert "not a readable VecNormalize file" in _evaluate_ppo(f"ppo:{bad}", capsys)
    (bad / "vecnormalize.pkl").unlink()
    assert "observation statistics" in _evaluate_ppo(f"ppo:{bad}", capsys)


def test_evaluate_reports_a_model_trained_with_another_preview(tiny_run, tmp_path, capsys):
    other = tmp_path / "preview20"
    shutil.copytree(tiny_run, other)
    cfg = yaml.safe_load((other / "config.yaml").read_text())
    # the same files, declared as trained with a 20 s preview: settings disagree with the env's
    cfg["env"]["preview_s"] = 20
    (other / "config.yaml").write_text(yaml.safe_dump(cfg))
    line = _evaluate_ppo(f"ppo:{other}", capsys)
    assert "preview_s=20" in line and "preview_s=10" in line


def test_a_policy_is_driven_with_the_band_center_it_was_trained_on(tiny_run, tmp_path):
    # ppo.yaml trains with env.reward.descent_recovery 0.15, not the env's default 0.6
    assert load_run_config(tiny_run)["env"]["reward"] == {"descent_recovery": 0.15}
    strategy = get_strategy(f"ppo:{tiny_run}")
    assert strategy.env_options() == {"reward": {"descent_recovery": 0.15}}
    env = HevThermalEnv(cycle="udds", scenario="hilly")  # the default center is not the one it learned
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"descent_recovery=0\.15; the env has 0\.6"):
        strategy.reset(env)
    env = HevThermalEnv(cycle="udds", scenario="hilly", **strategy.env_options())
    env.reset(seed=0)
    strategy.reset(env)
    # run_strategy builds the env with the strategy's options, so the run goes through
    res = run_strategy(strategy, tiny_cycle_csv(tmp_path / "short.csv"), "hilly")
    assert res.summary["duration_s"] == pytest.approx(90.0)
    # a run config without the key was trained on the env's default: nothing to pass, the default env fits
    other = tmp_path / "default_center"
    shutil.copytree(tiny_run, other)
    cfg = yaml.safe_load((other / "config.yaml").read_text())
    del cfg["env"]["reward"]
    (other / "config.yaml").write_text(yaml.safe_dump(cfg))
    strategy = get_strategy(f"ppo:{other}")
    assert strategy.env_options() == {}
    env = HevThermalEnv(cycle="udds", scenario="hilly")
    env.reset(seed=0)
    strategy.reset(env)


def test_model_with_another_observation_size_is_rejected(tmp_path, capsys):
    out = tmp_path / "p4"
    assert train.main(train_args(out, 256, "--eval-cycles", hp=("env.preview_s=4",))) == 0
    assert load_run_config(out)["env"]["observation_size"] == 18
    line = _evaluate_ppo(f"ppo:{out}", capsys)
    assert "expects 18 observation entries, the env gives 21" in line and "preview_s=4" in line
