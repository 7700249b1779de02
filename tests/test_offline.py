"""Offline datasets: written through Minari's DataCollector, loaded with ``minari.load_dataset``, replayed exactly; the
card names the physics and the task; training routes never include a held-out cycle."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import numpy as np
import pytest

from hev_thermal_env import load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.agents.ppo import trained_reward
from hev_thermal_env.evaluation import datasets
from hev_thermal_env.physics.fingerprint import physics_fingerprint
from hev_thermal_env.tasks import TEST_SEED_BASE, get_task, held_out_cycles

minari = pytest.importorskip("minari")


def replay(dataset: Any) -> tuple[float, float]:
    """Replay every episode's actions through the dataset's recovered env; returns the largest absolute difference
    of the observations and of the rewards from those stored (0 and 0 for an exact replay)."""
    env = dataset.recover_environment()
    resets = dataset.storage.metadata["hev_thermal_episodes"]
    worst_obs = worst_reward = 0.0
    try:
        for ep, spec in zip(dataset.iterate_episodes(), resets):
            obs, _ = env.reset(seed=spec["seed"], options={"cycle": spec["cycle"], "start_s": spec["start_s"]})
            seen, rewards = [obs], []
            for action in ep.actions:
                obs, reward, *_ = env.step(action)
                seen.append(obs)
                rewards.append(reward)
            worst_obs = max(worst_obs, float(np.max(np.abs(np.asarray(seen) - ep.observations))))
            worst_reward = max(worst_reward, float(np.max(np.abs(np.asarray(rewards) - ep.rewards))))
    finally:
        env.close()
    return worst_obs, worst_reward


@pytest.fixture(scope="module")
def short_routes(tmp_path_factory) -> list[str]:
    """Two slices of UDDS (41 s and 61 s) as CSV cycles."""
    folder = tmp_path_factory.mktemp("offline")
    paths = []
    for a, b in ((20, 61), (300, 361)):
        path = folder / f"udds_{a}_{b}.csv"
        v = load_cycle("udds").speed_mps[a:b]
        path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
        paths.append(str(path))
    return paths


@pytest.mark.parametrize("source", ["rule", "random"])
def test_round_trip_replays_observations_and_rewards_exactly(source, short_routes, tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    info = datasets.write_dataset(source, routes=short_routes, scenario="hot", root=tmp_path,
                           dataset_name=f"hev-thermal/test/{source}-v0")
    assert info["episodes"] == 2 and info["steps"] == 40 + 60 and info["bytes"] > 0
    data = minari.load_dataset(info["dataset_id"])
    assert data.total_episodes == 2 and data.total_steps == 100
    meta = data.storage.metadata
    assert meta["hev_thermal_physics_fingerprint"] == physics_fingerprint()
    assert meta["hev_thermal_routes"] == short_routes and meta["hev_thermal_source"] == source
    episodes = list(data.iterate_episodes())
    assert not np.allclose(episodes[0].actions[:5], 0.0) or source == "rule"
    assert replay(data) == (0.0, 0.0)


def test_a_policy_dataset_records_the_env_it_drove(short_routes, tmp_path, monkeypatch):
    # the shipped policy is driven with its own observation settings (PPOStrategy.env_options); the dataset's env
    # carries them, so the replay is exact on a graded route, where the band's center depends on them
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    info = datasets.write_dataset("ppo", routes=short_routes, scenario="hilly", root=tmp_path,
                           dataset_name="hev-thermal/test/ppo-v0")
    data = minari.load_dataset(info["dataset_id"])
    env = data.recover_environment()
    shipped = get_strategy("ppo")
    assert env.unwrapped.reward_params.descent_recovery == trained_reward(shipped.policy).descent_recovery
    env.close()
    assert replay(data) == (0.0, 0.0)
    # a policy cloned from it is driven in the env its observations came from
    from hev_thermal_env.training.fit import BCStrategy, train_bc

    record, _ = train_bc(info["dataset_id"], epochs=1)
    assert BCStrategy(record).env_options() == shipped.env_options()


def test_task_dataset_card(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    info = datasets.write_dataset("engine_only", task="hwfet", root=tmp_path)
    assert info["dataset_id"] == "hev-thermal/hwfet-v2/engine_only-v0"
    data = minari.load_dataset(info["dataset_id"])
    meta = data.storage.metadata
    assert meta["hev_thermal_task"] == "hwfet-v2" and meta["hev_thermal_task_digest"] == get_task("hwfet").digest()
    assert meta["algorithm_name"].endswith("engine_only") and meta["code_permalink"]
    assert np.all(np.concatenate([e.actions for e in data.iterate_episodes()]) == 0.0)  # the motor unused


def test_training_routes_are_not_held_out():
    routes = datasets.training_routes(12)
    assert len(set(routes)) == 12 and not {r.lower() for r in routes} & set(held_out_cycles())
    assert all(int(r.split(":")[1]) < TEST_SEED_BASE for r in routes)
    with pytest.raises(ValueError, match="held-out"):
        datasets.write_dataset("rule", routes=[get_task("bus-generalisation").cycles[0]])
    with pytest.raises(ValueError, match="not training families"):
        datasets.training_routes(2, ("validation_bus",))


@pytest.mark.full
def test_dataset_loads_in_a_fresh_process(short_routes, tmp_path):
    datasets.write_dataset("rule", routes=short_routes[:1], root=tmp_path, dataset_name="hev-thermal/test/fresh-v0")
    code = ("import minari, hev_thermal_env; d = minari.load_dataset('hev-thermal/test/fresh-v0'); "
            "env = d.recover_environment(); print(d.total_steps, env.spec.id)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300,
                         env={**__import__("os").environ, "MINARI_DATASETS_PATH": str(tmp_path)})
    assert out.stdout.split() == ["40", "HevThermal-v2"]


@pytest.mark.full
def test_behaviour_cloning_fits_a_dataset_and_drives(short_routes, tmp_path, monkeypatch):
    """BC on a tiny dataset of the rule strategy: the fit's error falls well below the actions' variance, and the
    cloned policy, saved and loaded, drives an episode within the action bounds."""
    from hev_thermal_env.training.fit import BCStrategy, load_bc, save_bc, train_bc

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    datasets.write_dataset("rule", routes=short_routes, scenario="hot", root=tmp_path,
                           dataset_name="hev-thermal/test/bc-v0")
    record, report = train_bc("hev-thermal/test/bc-v0", epochs=150, seed=0)
    assert report["pairs"] == 100 and report["mse_last"] < 0.25 * report["action_variance"]
    policy = BCStrategy(load_bc(save_bc(record, tmp_path / "bc.pt")))
    assert policy.env_options() == {}  # the rule's dataset was written in the env's own settings
    from hev_thermal_env.evaluation.runner import run_strategy

    res = run_strategy(policy, short_routes[1], "hot")
    assert res.trace["u"].size == 60 and np.all(np.abs(res.trace["u"]) <= 1.0)


@pytest.mark.full
def test_bc_command_writes_a_seed_family_for_the_leaderboard(short_routes, tmp_path, monkeypatch):
    """``evaluate.py bc`` on tiny inputs: two seeds fitted, one result file per task holding both seeds' episodes and
    each fit's wall-clock, valid for the leaderboard; a repeated seed is refused."""
    from hev_thermal_env.cli.evaluate import main as evaluate_main
    from hev_thermal_env.evaluation.submission import load_result

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    datasets.write_dataset("rule", routes=short_routes, scenario="paper", root=tmp_path,
                    dataset_name="hev-thermal/test/bccli-v0")
    out = tmp_path / "res"
    code = evaluate_main(["bc", "--dataset", "hev-thermal/test/bccli-v0", "--tasks", "hwfet", "--seeds", "0", "1",
                          "--epochs", "2", "--results-dir", str(out), "--policy", str(tmp_path / "bc.pt")])
    assert code == 0
    result = load_result(out / "hwfet-v2" / "bc.json")
    assert result["seeds"] == [0, 1] and [r["seed"] for r in result["episodes"]] == [0, 1]
    assert len(result["training"]["wall_clock_s_per_seed"]) == 2
    assert (tmp_path / "bc_seed0.pt").is_file() and (tmp_path / "bc_seed1.pt").is_file()
    assert evaluate_main(["bc", "--dataset", "hev-thermal/test/bccli-v0", "--tasks", "hwfet", "--seeds", "1", "1",
                          "--results-dir", str(out)]) == 2
