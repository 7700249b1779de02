"""The learned baselines of ``train.py`` beyond PPO and SAC: TQC, RecurrentPPO and PPO-Lagrangian train, save, reload
and drive ``evaluate.py``; the Lagrange multiplier's update rule on synthetic costs; a recurrent policy's state carried
within an episode and cleared between episodes; the hyperparameter files checked."""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv

import evaluate
import train
from hev_thermal_env import load_cycle
from hev_thermal_env.agents import HYPERPARAMS_DIR, list_strategies
from hev_thermal_env.agents.policy_files import ALGORITHMS, load_policy
from hev_thermal_env.agents.ppo import PPOStrategy
from hev_thermal_env.evaluation.benchmark import parse_family
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.submission import load_result
from hev_thermal_env.tasks import get_task
from hev_thermal_env.training import build_config
from hev_thermal_env.training.config import load_run_config
from hev_thermal_env.training.envs import PolicyEvaluator
from hev_thermal_env.training.lagrangian import LagrangeMultiplier, LagrangianVecEnv, dual_ascent

ROOT = Path(__file__).resolve().parents[1]



# tiny runs of each method: 2 envs, 256 env-steps, no periodic evaluation
COMMON = ["--timesteps", "256", "--n-envs", "2", "--seed", "0", "--no-progress", "--quiet", "--eval-cycles",
          "--checkpoint-freq", "128"]
TINY = {
    "tqc": ["learning_starts=64", "buffer_size=500", "batch_size=16", "policy_kwargs.net_arch=[8,8]",
            "policy_kwargs.n_quantiles=5"],
    "recurrent_ppo": ["n_steps=32", "batch_size=32", "n_epochs=1", "policy_kwargs.net_arch=[8,8]",
                      "policy_kwargs.lstm_hidden_size=8"],
    "ppo_lagrangian": ["n_steps=32", "batch_size=32", "n_epochs=1", "policy_kwargs.net_arch=[8,8]",
                       "init.imitate=null", "policy_kwargs.log_std_init=0.0", "constraint.budget_s_per_h=0",
                       "constraint.lambda_lr=0.01"],
}


def short_cycle(path: Path, n: int = 120) -> str:
    v = load_cycle("us06").speed_mps[30:30 + n]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return str(path)


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """One tiny run per method; PPO-Lagrangian on 120 s of US06 in ``weak_loop`` (a warm motor, a 40 °C day, the
    pump at 10 %), so that episodes end with a safety cost and λ moves."""
    d = tmp_path_factory.mktemp("baselines")
    out = {}
    for algo, hp in TINY.items():
        extra = (["--cycles", short_cycle(d / "short.csv"), "--scenario", "weak_loop"] if algo == "ppo_lagrangian"
                 else ["--task", "bus-generalisation"])
        out[algo] = d / algo
        assert train.main(["--algo", algo, *extra, "--out", str(out[algo]), *COMMON, "--hp", *hp]) == 0, algo
    return out


@pytest.mark.parametrize("algo", list(TINY))
def test_each_method_trains_reloads_and_drives_evaluate(runs, algo, tmp_path):
    run = runs[algo]
    cfg = load_run_config(run)
    assert cfg["algo"] == algo and cfg["result"]["finished"] and cfg["result"]["timesteps_done"] == 256
    policy = load_policy(run)
    assert type(policy.model).__name__ == ALGORITHMS[algo].split(":")[1]
    summary = tmp_path / "summary.json"
    assert evaluate.main(["run", "--cycle", "us06", "--strategy", f"ppo:{run}", "--json", str(summary)]) == 0
    data = json.loads(summary.read_text())
    found = data.get("summary", data)
    assert found["duration_s"] == load_cycle("us06").n_steps


def test_the_generalisation_task_sets_the_training_distribution(runs):
    cfg = load_run_config(runs["tqc"])
    assert cfg["task"] == "bus-generalisation-v1" and cfg["env"]["scenario"] == "random_service"
    assert cfg["env"]["cycles"][0] == "random_bus" and len(cfg["env"]["observation_names"]) == 21


def test_tqc_checkpoints_its_replay_buffer(runs):
    assert (runs["tqc"] / "checkpoints" / "ckpt_256_steps_replay_buffer.pkl").is_file()


# --- PPO-Lagrangian ---------------------------------------------------------------------------------

def test_dual_ascent_rises_over_the_budget_falls_under_it_and_stays_in_bounds():
    m = LagrangeMultiplier(budget_s_per_h=36.0, lambda_lr=0.01, lambda_init=0.0, lambda_max=2.0)
    lams = []
    for _ in range(5):  # 72 s of safety cost per hour driven: twice the budget
        m.record_episode(cost_s=36.0, duration_s=1800.0)
        m.update(0)
        lams.append(m.lam)
    assert lams == pytest.approx([0.36, 0.72, 1.08, 1.44, 1.8])
    m.record_episode(cost_s=0.0, duration_s=3600.0)  # no safety cost: 36 s/h under the budget
    m.update(0)
    assert m.lam == pytest.approx(1.44)
    for _ in range(10):
        m.record_episode(cost_s=0.0, duration_s=3600.0)
        m.update(0)
    assert m.lam == 0.0  # never negative
    for _ in range(10):
        m.record_episode(cost_s=3600.0, duration_s=3600.0)
        m.update(0)
    assert m.lam == 2.0  # capped
    assert m.update(0) is None and m.lam == 2.0  # no episode since the last update: no step
    assert dual_ascent(1.0, 10.0, 10.0, 5.0, 9.0) == 1.0  # at the budget λ stays


def test_multiplier_pools_episodes_by_hours_driven():
    m = LagrangeMultiplier(budget_s_per_h=0.0, lambda_lr=1.0)
    m.record_episode(cost_s=10.0, duration_s=3600.0)
    m.record_episode(cost_s=0.0, duration_s=1800.0)
    assert m.update(100) == pytest.approx(10.0 / 1.5)
    assert m.history[-1]["episodes"] == 2 and m.history[-1]["timesteps"] == 100


class _CostEnv(VecEnv):
    """Two envs; reward −1 and cost 0.5 every step, env 0's episodes end every 3 steps."""

    def __init__(self):
        box = spaces.Box(-1.0, 1.0, (1,), np.float32)
        super().__init__(2, box, box)
        self.t = 0

    def reset(self):
        return np.zeros((2, 1), np.float32)

    def step_async(self, actions):
        pass

    def step_wait(self):
        self.t += 1
        dones = np.array([self.t % 3 == 0, False])
        return (np.zeros((2, 1), np.float32), np.full(2, -1.0, np.float32), dones,
                [{"cost": 0.5}, {"cost": 0.5}])

    def close(self):
        pass

    def get_attr(self, *a, **k):
        return [None, None]

    def set_attr(self, *a, **k):
        pass

    def env_method(self, *a, **k):
        return []

    def env_is_wrapped(self, *a, **k):
        return [False, False]


def test_wrapper_prices_the_cost_in_and_updates_once_per_rollout():
    m = LagrangeMultiplier(budget_s_per_h=0.0, lambda_lr=0.001, lambda_init=2.0, lambda_max=100.0)
    env = LagrangianVecEnv(_CostEnv(), m, update_every=3, dt_s=1.0)
    env.reset()
    _, r, _, _ = env.step(np.zeros((2, 1)))
    np.testing.assert_allclose(r, [-1.0 - 2.0 * 0.5] * 2)
    env.step(np.zeros((2, 1)))
    assert m.lam == 2.0  # no update within a rollout
    env.step(np.zeros((2, 1)))  # third call: env 0's episode (1.5 s of cost in 3 s) ends, then λ steps
    assert m.history[-1]["cost_s_per_h"] == pytest.approx(1800.0)
    assert m.lam == pytest.approx(2.0 + 0.001 * 1800.0)
    _, r, _, _ = env.step(np.zeros((2, 1)))
    np.testing.assert_allclose(r, [-1.0 - m.lam * 0.5] * 2)


def test_lagrangian_run_records_its_multiplier(runs):
    run = runs["ppo_lagrangian"]
    res = load_run_config(run)["result"]["lagrangian"]
    with open(run / "lagrangian.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert rows and res["updates"] == len(rows)
    assert float(rows[-1]["lambda"]) == pytest.approx(res["lambda"], abs=1e-6)  # the CSV keeps 6 decimals
    # a budget of 0: λ rises exactly when episodes had a safety cost, and never falls
    lams = [float(r["lambda"]) for r in rows]
    costs = [float(r["cost_s_per_h"]) for r in rows]
    assert max(costs) > 0.0 and lams[-1] > 0.0
    for before, after, cost in zip([0.0, *lams], lams, costs):
        assert after == pytest.approx(min(50.0, before + 0.01 * cost), abs=1e-5)
    saved = json.loads((run / "checkpoints" / "ckpt_256_steps_lagrangian.json").read_text())
    assert saved["lambda"] == pytest.approx(res["lambda"], abs=1e-6)  # the result keeps 6 decimals


def test_a_resumed_lagrangian_run_continues_its_multiplier(runs, tmp_path):
    run = tmp_path / "resumed"
    shutil.copytree(runs["ppo_lagrangian"], run)
    with open(run / "lagrangian.csv", newline="") as fh:
        before = list(csv.DictReader(fh))
    cfg = yaml.safe_load((run / "config.yaml").read_text())
    cfg["total_timesteps"], cfg["result"]["finished"] = 384, False
    (run / "config.yaml").write_text(yaml.safe_dump(cfg))
    (run / "model.zip").unlink()
    assert train.main(["--resume", str(run), "--no-progress", "--quiet"]) == 0
    with open(run / "lagrangian.csv", newline="") as fh:
        after = list(csv.DictReader(fh))
    assert after[:len(before)] == before and len(after) > len(before)
    assert all(256 < int(r["timesteps"]) <= 384 for r in after[len(before):])
    first_new = after[len(before)]
    lam = min(50.0, float(before[-1]["lambda"]) + 0.01 * float(first_new["cost_s_per_h"]))
    assert float(first_new["lambda"]) == pytest.approx(lam, abs=1e-5)


def test_constraint_settings_are_checked():
    with pytest.raises(ValueError, match="unconstrained"):
        build_config("ppo", overrides={"constraint.budget_s_per_h": 1.0})
    with pytest.raises(ValueError, match="lambda_lr"):
        build_config("ppo_lagrangian", overrides={"constraint.lambda_lr": -1})
    with pytest.raises(ValueError, match="no current safety budget is stored for task None"):
        build_config("ppo_lagrangian", overrides={"constraint.budget_s_per_h": "task"})


def test_the_task_budget_is_the_stored_episode_budget_per_hour_driven():
    """``budget_s_per_h: task`` reads the task's stored reference: hwfet-v1's episode budget over HWFET's hours."""
    from hev_thermal_env.evaluation.references import load_reference
    from hev_thermal_env.training.lagrangian import task_budget_s_per_h

    budget_s = load_reference("hwfet-v1")["safety_budget_s"]
    assert budget_s >= 10.0
    assert task_budget_s_per_h("hwfet-v1") == pytest.approx(budget_s / (765 / 3600.0), rel=1e-12)
    assert task_budget_s_per_h(None) is None
    with pytest.raises(ValueError, match="PPO runs only"):
        build_config("tqc", overrides={"init.imitate": "ecms"})


# --- the recurrent policy's state ---------------------------------------------------------------------

def test_recurrent_policy_carries_its_state_and_a_reset_clears_it(runs):
    policy = load_policy(runs["recurrent_ppo"])
    assert policy.recurrent
    obs = np.random.default_rng(0).normal(size=(5, policy.obs_dim)).astype(np.float32)
    first = policy.act(obs[:1])
    states = [policy.act(obs[i:i + 1]) for i in range(1, 5)]
    again = policy.act(obs[:1])  # the same observation after four steps: another state, another action
    assert not np.allclose(again, first)
    policy.reset_state()
    np.testing.assert_array_equal(policy.act(obs[:1]), first)
    assert len(states) == 4


def test_recurrent_strategy_and_training_evaluation_start_each_episode_afresh(runs):
    strategy = PPOStrategy(runs["recurrent_ppo"])
    a = run_strategy(strategy, "us06", "paper").summary
    b = run_strategy(strategy, "us06", "paper").summary
    assert a["fuel_corrected_l_per_100km"] == b["fuel_corrected_l_per_100km"]
    cfg = load_run_config(runs["recurrent_ppo"])
    policy = load_policy(runs["recurrent_ppo"])
    first, second = PolicyEvaluator(cfg["env"], ["us06"], ["paper", "paper"]).run(policy.act)
    assert first["return_g"] == second["return_g"]
    assert first["fuel_corrected_l_per_100km"] == pytest.approx(a["fuel_corrected_l_per_100km"], rel=1e-9)


# --- the hyperparameter files ------------------------------------------------------------------------

@pytest.mark.parametrize("algo", list(ALGORITHMS))
def test_every_algorithm_has_a_checked_hyperparameter_file_on_the_same_observation(algo):
    assert (HYPERPARAMS_DIR / f"{algo}.yaml").is_file()
    cfg = build_config(algo, task="bus-generalisation")
    ppo = build_config("ppo", task="bus-generalisation")
    assert cfg["env"]["observation_names"] == ppo["env"]["observation_names"]
    assert cfg["env"]["cycles"] == ppo["env"]["cycles"] and cfg["env"]["scenario"] == ppo["env"]["scenario"]
    assert cfg["total_timesteps"] >= 100_000


#: The RL track's hyperparameter files, stored as rl-zoo3 files: file name -> (train.py's algorithm, rl-zoo3's).
ZOO_FILES = {"sac": ("sac", "sac"), "tqc": ("tqc", "tqc"), "recurrent_ppo": ("recurrent_ppo", "ppo_lstm"),
             "ppo_rl": ("ppo", "ppo")}


@pytest.mark.parametrize("name", list(ZOO_FILES))
def test_the_rl_tracks_files_are_rl_zoo3_files_that_train_py_reads_alike(name):
    """An rl-zoo3 file: one section for the env id (its env_kwargs gymnasium.make's, policy_kwargs rl-zoo3's string)
    and train.py's own settings apart; train.py reads the same hyperparameters from it, and the env its
    env_kwargs make is the one train.py trains on."""
    import gymnasium as gym

    from hev_thermal_env.evaluation.submission import track_of
    from hev_thermal_env.tasks import ENV_ID
    from hev_thermal_env.training.hyperparams import PROJECT_SECTION, load_hyperparams

    algo = ZOO_FILES[name][0]
    path = ROOT / "agents" / "hyperparams" / f"{name}.yaml"  # this checkout's, as rl-zoo3 is given it
    raw = yaml.safe_load(path.read_text())
    assert set(raw) == {ENV_ID, PROJECT_SECTION}
    zoo = raw[ENV_ID]
    assert isinstance(zoo["policy_kwargs"], str) and zoo["policy_kwargs"].startswith("dict(")
    hp = load_hyperparams(algo, path)
    assert hp["env"]["cycles"] == zoo["env_kwargs"]["cycle"] and hp["n_timesteps"] == zoo["n_timesteps"]
    assert hp["policy_kwargs"]["activation_fn"] in ("relu", "tanh") and hp["policy_kwargs"]["net_arch"] == [64, 64]
    assert hp["normalize"] == {"norm_obs": True, "norm_reward": True, "clip_obs": 10.0, "clip_reward": 10.0}
    env = gym.make(ENV_ID, **zoo["env_kwargs"])
    try:
        cfg = build_config(algo, hyperparams_file=path, task="bus-generalisation")
        assert env.observation_space.shape == (cfg["env"]["observation_size"],)
        assert track_of(cfg) == "RL"
    finally:
        env.close()


@pytest.mark.parametrize("text, message", [
    ("dict(net_arch=[8], activation_fn=nn.Softsign)", "nn.Softsign: expected one of"),
    ("dict(net_arch=__import__('os'))", "policy_kwargs"),
    ("[1, 2]", r"expected dict\(key=value"),
])
def test_an_rl_zoo3_string_is_read_without_evaluating_it(text, message):
    from hev_thermal_env.training.hyperparams import zoo_mapping

    assert zoo_mapping("dict(net_arch=[8, 8], activation_fn=nn.Tanh, n_quantiles=5)", "x") == {
        "net_arch": [8, 8], "activation_fn": "tanh", "n_quantiles": 5}
    with pytest.raises(ValueError, match=message):
        zoo_mapping(text, "policy_kwargs")


@pytest.mark.full
def test_rl_zoo3_trains_sac_from_its_hyperparameter_file_as_written(tmp_path):
    """The command of docs/training.md, with rl-zoo3's own --n-timesteps and log folder, in a temp dir: rl-zoo3 reads
    sac.yaml unchanged, builds HevThermal-v2 from its env_kwargs and saves the model and its statistics."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "sac", "--env", "HevThermal-v2", "--gym-packages",
           "hev_thermal_env", "--conf-file", str(ROOT / "agents" / "hyperparams" / "sac.yaml"),
           "--n-timesteps", "1000", "--log-folder", str(tmp_path / "logs")]
    done = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    run = tmp_path / "logs" / "sac" / "HevThermal-v2_1"
    assert (run / "HevThermal-v2.zip").is_file() and (run / "HevThermal-v2" / "vecnormalize.pkl").is_file()
    assert "Overwriting n_timesteps with n=1000" in done.stdout


# --- benchmarks/learned_baselines.py --------------------------------------------------------------------

def _script():
    spec = importlib.util.spec_from_file_location("learned_baselines", ROOT / "benchmarks" / "learned_baselines.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_benchmark_covers_every_algorithm_with_fixed_seeds_and_valid_family_names():
    script = _script()
    assert set(script.METHODS) == set(ALGORITHMS) | set(script.FROM_FILE) == set(script.SMOKE_ARGS) == set(
        script.FAMILY_NAMES)
    assert all(algo in ALGORITHMS and (ROOT / path).is_file() for algo, path in script.FROM_FILE.values())
    assert script.SEEDS == (0, 1, 2, 3, 4)
    for name in script.FAMILY_NAMES.values():  # a seed family may not take a strategy's name
        assert parse_family(f"{name}={ROOT},{ROOT / 'agents'}", taken=list_strategies()).name == name


@pytest.mark.full
def test_the_benchmark_smoke_run_writes_its_json(tmp_path):
    """Four methods, two seeds, tiny budgets, scored on hwfet against its stored reference (no optimum solved); each
    family's track read from its runs' configs (PPO starts from a teacher's actions, PPO from its RL file and
    RecurrentPPO have the reward alone, BC is guided)."""
    script = _script()
    assert script.main(["--smoke", "--methods", "ppo", "ppo_rl", "recurrent_ppo", "bc", "--out", str(tmp_path)]) == 0
    task = get_task(script.SMOKE_TASKS[0]).id
    record = json.loads((tmp_path / "learned_baselines.json").read_text())
    for method in ("ppo", "ppo_rl", "recurrent_ppo"):
        seeds = record["methods"][method]["seeds"]
        assert [s["seed"] for s in seeds] == [0, 1] and all(s["steps_per_s"] > 0 for s in seeds)
        assert all(Path(s["policy"]).is_file() for s in seeds)
        ev = record["evaluation"][task]["methods"][method]
        assert ev["runs"] == 2 and len(ev["episodes"]) == 2 and ev["scored_runs"] + ev["runs_without_score"] == 2
        if ev["scored_runs"]:  # an untrained policy scores far below the optimum, and never above it
            assert ev["score_iqm"] <= 100.0 + 1e-6 and ev["frontier_ratio_iqm"] >= 1.0 - 1e-6
        assert ev["safety_cost_s_iqm"] >= 0.0 and ev["max_abs_delta_soc"] >= 0.0
        assert 0 <= ev["above_optimum_safety"] <= 2 and 0 <= ev["beyond_soc_bound"] <= 2
        name = script.FILE_NAMES.get(method, script.FAMILY_NAMES[method])
        result = load_result(tmp_path / "learned_baselines" / task / f"{name}.json")
        assert result["seeds"] == [0, 1] and len(result["training"]["wall_clock_s_per_seed"]) == 2
        assert result["track"] == ev["track"] == {"ppo": "guided", "ppo_rl": "RL", "recurrent_ppo": "RL"}[method]
    bc = record["evaluation"][task]["methods"]["bc"]  # behaviour cloning: two fits of a tiny dataset
    assert bc["runs"] == 2 and len(bc["training_wall_s_per_seed"]) == 2 and record["bc"]["seeds"] == [0, 1]
    assert load_result(tmp_path / "learned_baselines" / task / "BC.json")["seeds"] == [0, 1]
    assert bc["track"] == "guided"
    table = (tmp_path / "learned_baselines.md").read_text()
    assert f"| {task} | RecurrentPPO | RL |" in table and f"| {task} | BC (optimum) | guided |" in table
    assert not (tmp_path / "learned_baselines_curves.png").exists()  # the smoke runs evaluate nothing: no curves


def test_the_table_shows_a_method_without_scores_or_interval():
    """A family whose runs end off the optimum's frontier has no ratio; one with a single scored episode no interval."""
    lb = _script()
    m = {"track": "guided",
         "frontier_ratio_iqm": None, "frontier_ratio_ci95": [None, None], "score_iqm": None, "score_ci95": [None, None],
         "runs_without_score": 5, "max_abs_delta_soc": 0.03, "safety_cost_s_iqm": 876.9, "safety_cost_s_max": 900.0,
         "runs": 5, "beyond_soc_bound": 2, "above_optimum_safety": 5}
    one = {**m, "frontier_ratio_iqm": 1.0991, "score_iqm": 59.1, "runs_without_score": 4}
    record = {"evaluation": {"udds-hot-v1": {"safety_budget_s": 10.0, "methods": {"bc": m}},
                             "hilly-v1": {"safety_budget_s": 29.962, "methods": {"bc": one}}}}
    lines = lb.table(record).splitlines()
    assert lines[2].startswith("| udds-hot-v1 | BC (optimum) | guided | - | - | 876.9; 900.0 | 10 | 5 | 0.030 (2) | "
                               "5 (5 without a")
    assert "| 1.0991 | 876.9; 900.0 | 29.962 |" in lines[3]


def test_learning_curves_of_two_seeds(tmp_path):
    from hev_thermal_env.training.artifacts import EVAL_COLUMNS, write_evaluations

    script = _script()
    seeds = []
    for seed in (0, 1):
        run = tmp_path / f"seed_{seed}"
        run.mkdir()
        rows = [{**dict.fromkeys(EVAL_COLUMNS, 0.0), "timesteps": t, "cycle": "c", "scenario": "paper",
                 "fuel_ratio": 1.02 - 0.001 * k - 0.002 * seed, "qualified": k > 0, "best": k == 2}
                for k, t in enumerate((1000, 2000, 3000))]
        write_evaluations(run / "evaluations.csv", rows)
        seeds.append({"seed": seed, "run_dir": str(run)})
    path = script.learning_curves({"ppo": {"seeds": seeds}}, tmp_path / "curves.png")
    assert path.stat().st_size > 10_000
    assert script.learning_curves({"ppo": {"seeds": [{"seed": 0, "run_dir": str(tmp_path / "none")}]}},
                                  tmp_path / "none.png") is None


def test_an_extra_family_must_be_finished_runs_under_a_new_name(tmp_path):
    script = _script()
    with pytest.raises(SystemExit, match="no finished run in"):
        script.main(["--smoke", "--methods", "ppo", "--also", f"variant={tmp_path}", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="expected NAME=DIR with a new name"):
        script.main(["--smoke", "--methods", "ppo", "--also", f"PPO={tmp_path}", "--out", str(tmp_path)])
    assert not (tmp_path / "runs").exists()  # refused before anything trained


def test_an_extra_family_is_scored_with_its_best_or_its_final_model(runs):
    """``--also``: a family's policy is each run's ``best_model.zip``; ``--also-final`` its final ``model.zip``."""
    script = _script()
    run = runs["tqc"]
    best, final = script.seed_record(run, 0), script.seed_record(run, 0, "model.zip")
    assert best["policy"] == str(run / "best_model.zip") and final["policy"] == str(run / "model.zip")
    assert {k: v for k, v in best.items() if k != "policy"} == {k: v for k, v in final.items() if k != "policy"}
    assert (run / "model.zip").is_file() and (run / "best_model.zip").is_file()
    assert script.parse_args(["--also", "x=y", "--also-final"]).also_final
    assert not script.parse_args(["--also", "x=y"]).also_final
