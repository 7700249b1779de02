"""The named tasks: each resolves and runs, its definition is pinned to its version, the generalisation task's test
routes are disjoint from every training and validation cycle, and ``train.py`` / ``evaluate.py benchmark`` take
``--task``."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from hev_thermal_env import load_cycle, paper_bus
from hev_thermal_env.cycles.families import (
    FAMILIES,
    TRAINING_SEED_LIMIT,
    VALIDATION_SEED_BASE,
    inner_seed,
    training_seed,
)
from hev_thermal_env.cycles.names import VALIDATION_SIZE, validation_cycle, validation_seed
from hev_thermal_env.scenarios import get_scenario
from hev_thermal_env.tasks import (
    TASK_ARGS,
    TASKS,
    TEST_FAMILIES,
    TRAINING_FAMILIES,
    Task,
    generalisation_cycles,
    get_task,
    held_out_cycles,
    list_tasks,
    make_task,
)

#: Each version's definition (Task.digest): a change under an existing id fails here; give the changed task a new
#: version instead.
DIGESTS = {
    "hwfet-v1": "f3b8cb098f6d",
    "beijing-v1": "776a6852e1ec",
    "udds-hot-v1": "b4dcdc914254",
    "hilly-v1": "34782bff794a",
    "full-bus-v1": "e3e6cda05442",
    "summer-v1": "8c20d4c731e5",
    "bus-generalisation-v1": "8990109ebd3d",
    "hwfet-v2": "e17bb4398281",
    "beijing-v2": "ad7012630465",
    "udds-weak-loop-v2": "d52bb40fbaf9",
    "udds-hilly-weak-loop-v2": "48bd086a3de9",
    "udds-hilly-evening-v2": "11fff4a8676d",
    "udds-hilly-fan-failed-v2": "69d276a8b06c",
}
_FAMILY_SEED = re.compile(r"^([a-z_]+):(\d+)$")

ROOT = Path(__file__).resolve().parents[1]


# --- the registry ------------------------------------------------------------------------------------------------

def test_the_registry_names_each_task_once_with_its_version():
    assert list_tasks() == list(DIGESTS)
    for tid, task in TASKS.items():
        newest = max(t.version for t in TASKS.values() if t.name == task.name)
        assert tid == task.id == f"{task.name}-v{task.version}"
        assert (get_task(task.name) is task) == (task.version == newest)
        assert get_task(tid.upper()) is task
        assert task.env_id == f"HevThermal-v{task.physics}" and make_task(tid).spec.id == task.env_id
        assert task.n_episodes == len(task.resets()) >= 1 and task.start_s == 0
        assert json.loads(json.dumps(task.to_dict()))["id"] == tid
    with pytest.raises(ValueError, match=r"unknown task 'hwfet-v8'; tasks: hwfet-v1, beijing-v1"):
        get_task("hwfet-v8")
    with pytest.raises(ValueError, match="cycle, scenario belong"):
        make_task("hwfet", cycle="udds", scenario="hot")
    with pytest.raises(ValueError, match="soc_offset belong"):  # a start off the reference's start is another episode
        make_task("hwfet", soc_offset=0.05)
    assert set(TASK_ARGS) >= set(get_task("hwfet").env_kwargs())


def test_a_name_alone_is_its_newest_version(monkeypatch):
    newer = Task("hwfet", 9, "a later definition", ("hwfet",), "hot")
    monkeypatch.setitem(TASKS, newer.id, newer)
    assert get_task("hwfet") is newer and get_task("hwfet-v1") is TASKS["hwfet-v1"]


def test_the_physics_is_not_the_episodes():
    """hwfet-v1 and hwfet-v2 drive the same episodes on two physics versions: the digest hashes the episodes (after
    the record's own id), the fingerprint the physics."""
    v1, v2 = get_task("hwfet-v1"), get_task("hwfet-v2")
    assert (v1.cycles, v1.scenario, v1.seeds) == (v2.cycles, v2.scenario, v2.seeds)
    assert v1.fingerprint() != v2.fingerprint()


@pytest.mark.parametrize("tid", list(DIGESTS))
def test_each_definition_is_pinned_to_its_version(tid):
    digest = get_task(tid).digest()
    assert digest[:12] == DIGESTS[tid], (
        f"{tid}: its episodes changed (digest {digest[:12]}); define a new version of the task rather than change "
        f"this one, or, if no published result used it yet, update DIGESTS")


@pytest.mark.parametrize("tid", list(DIGESTS))
def test_every_task_resolves_and_runs(tid):
    task = get_task(tid)
    env = make_task(tid, info_keys=("cost", "time_s", "cycle_id"))
    for seed, options in (task.resets()[0], task.resets()[-1]):
        _, info = env.reset(seed=seed, options=options)
        e, scenario = env.unwrapped, get_scenario(task.scenario)
        assert e.cycle.name == scenario.prepare_cycle(load_cycle(options["cycle"])).name and info["time_s"] == 0.0
        assert e.conditions == scenario.conditions
        for _ in range(5):
            obs, reward, term, trunc, info = env.step(env.action_space.sample())
            assert np.isfinite(obs).all() and np.isfinite(reward) and not term and not trunc
        assert info["time_s"] == 5.0 and info["cost"] >= 0.0
    vec = make_task(tid, num_envs=2)
    vec.reset(seed=[s for s, _ in task.resets()[:1]] * 2, options=[o for _, o in task.resets()[:1]] * 2)
    assert vec.step(np.zeros((2, 1), np.float32))[0].shape == (2, 21)


def test_an_episode_of_a_fixed_scenario_does_not_depend_on_the_seed():
    """Why the tasks with a fixed scenario have one seed: a fixed scenario starting at second 0 draws nothing."""
    task = get_task("hilly")
    env = make_task(task)
    actions = np.random.default_rng(0).uniform(-1, 1, (300, 1)).astype(np.float32)
    runs = []
    for seed in (0, 12345):
        obs, _ = env.reset(seed=seed, options=task.resets()[0][1])
        runs.append([obs] + [env.step(a)[0] for a in actions])
    np.testing.assert_array_equal(np.array(runs[0]), np.array(runs[1]))
    assert np.any(env.unwrapped.cycle.grade != 0.0)  # the scenario's road under the cycle


# --- the generalisation task's test set ------------------------------------------------------------------------

def _family_and_seed(name: str) -> tuple[str, int]:
    m = _FAMILY_SEED.match(name)
    assert m is not None and m.group(1) in FAMILIES, name
    return m.group(1), int(m.group(2))


def _generator_seeds(cycle) -> set[int]:
    """Every seed that generated a family cycle (its draws, segments and road), from its metadata."""
    meta = cycle.metadata
    family, seed = meta["family"], meta["seed"]
    seeds = {inner_seed(family, seed, 0)} | {s["seed"] for s in meta["segments"]}
    if meta["grade_profile"] is not None:
        seeds.add(meta["grade_profile"]["seed"])
    return seeds


def test_the_test_routes_use_seeds_no_training_run_and_no_validation_cycle_uses():
    task = get_task("bus-generalisation")
    assert task.held_out and task.cycles == generalisation_cycles() and len(set(task.cycles)) == len(task.cycles)
    pairs = [_family_and_seed(c) for c in task.cycles]
    assert [f for f, _ in pairs] == [TEST_FAMILIES[k % len(TEST_FAMILIES)] for k in range(len(pairs))]
    validation_seeds = {validation_seed(k) for k in range(VALIDATION_SIZE)}
    for _, seed in pairs:
        # training draws rng.integers(TRAINING_SEED_LIMIT): below the limit; the validation set: 30 seeds from its base
        assert seed >= TRAINING_SEED_LIMIT and seed not in validation_seeds
        assert seed >= VALIDATION_SEED_BASE + VALIDATION_SIZE
    rng = np.random.default_rng(7)
    assert max(training_seed(rng, "bus_long") for _ in range(20_000)) < TRAINING_SEED_LIMIT
    # every generator seed of a test route decodes to its own (family, seed): inner_seed is injective, so no other
    # cycle shares one; and each lies above the largest generator seed of any training cycle
    largest_training = inner_seed(list(FAMILIES)[-1], TRAINING_SEED_LIMIT - 1, 63)
    test_gen: set[int] = set()
    for name, (family, seed) in zip(task.cycles, pairs):
        cyc = load_cycle(name)
        assert cyc.metadata["family"] == family and cyc.metadata["seed"] == seed
        for g in _generator_seeds(cyc):
            assert (g - 2**48) // 64 // 64 == seed and list(FAMILIES)[(g - 2**48) // 64 % 64] == family
            assert g > largest_training
        test_gen |= _generator_seeds(cyc)
    validation = [validation_cycle(k) for k in range(VALIDATION_SIZE)]
    assert not test_gen & set().union(*(_generator_seeds(c) for c in validation))
    speeds = {load_cycle(name).speed_mps.tobytes() for name in task.cycles}
    assert not speeds & {c.speed_mps.tobytes() for c in validation}


def test_the_training_side_matches_the_training_defaults_and_refuses_the_test_set():
    pytest.importorskip("stable_baselines3")
    from hev_thermal_env.training.config import ENV_DEFAULTS, build_config
    from hev_thermal_env.training.hyperparams import load_hyperparams

    assert list(TRAINING_FAMILIES) == ENV_DEFAULTS["cycles"] == load_hyperparams("ppo")["env"]["cycles"]
    assert set(held_out_cycles()) == {c.lower() for c in generalisation_cycles()}
    test_cycle = generalisation_cycles()[4]
    with pytest.raises(ValueError, match=rf"env.cycles: '{test_cycle}' is a test cycle of the benchmark task "
                                         r"bus-generalisation-v1"):
        build_config("ppo", cycles=["bus_long", test_cycle])
    with pytest.raises(ValueError, match=rf"eval.cycles: '{test_cycle}' is a test cycle"):
        build_config("ppo", eval_cycles=[test_cycle])
    with pytest.raises(ValueError, match="held-out test set"):
        build_config("ppo", eval_cycles=["bus_mixed:2148532224..2148532230"])


def test_train_task_sets_the_training_cycles_and_scenario():
    pytest.importorskip("stable_baselines3")
    from hev_thermal_env.training.config import build_config

    gen = build_config("ppo", task="bus-generalisation", timesteps=64)
    assert gen["task"] == "bus-generalisation-v1" and gen["env"]["scenario"] == "random_service"
    assert gen["env"]["cycles"] == list(TRAINING_FAMILIES)
    one = build_config("ppo", task="udds-hot-v1", timesteps=64)
    assert (one["task"], one["env"]["cycles"], one["env"]["scenario"]) == ("udds-hot-v1", ["udds"], "hot")
    assert build_config("ppo", timesteps=64)["task"] is None
    with pytest.raises(ValueError, match="--task hwfet sets the training cycles and scenario"):
        build_config("ppo", task="hwfet", cycles=["udds"])
    with pytest.raises(ValueError, match="--task hwfet sets the training cycles and scenario; drop --hp env.scenario"):
        build_config("ppo", task="hwfet", overrides={"env.scenario": "hot"})
    from hev_thermal_env.cli.train import build_parser

    assert build_parser().parse_args(["--task", "summer", "--out", "x"]).task == "summer"


# --- evaluate.py benchmark --task ------------------------------------------------------------------------------

def test_benchmark_task_runs_the_tasks_cycles_and_scenario(tmp_path, monkeypatch, capsys):
    from hev_thermal_env.cli.evaluate import main

    path = tmp_path / "udds_61s.csv"
    v = load_cycle("udds").speed_mps[20:81]
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    tiny = Task("tiny", 1, "61 s of UDDS, hot", (str(path),), "hot")
    monkeypatch.setitem(TASKS, tiny.id, tiny)
    out = tmp_path / "bench"
    assert main(["benchmark", "--task", "tiny", "--strategies", "engine_only", "--jobs", "1", "--no-plots",
                 "--out", str(out)]) == 0
    assert "task tiny-v1: 61 s of UDDS, hot" in capsys.readouterr().out
    rows = json.loads((out / "results.json").read_text())
    rows = rows["rows"] if isinstance(rows, dict) else rows
    assert {(r["cycle"], r["scenario"]) for r in rows} == {("udds_61s", "hot")}
    record = json.loads((out / "task.json").read_text())
    assert record["id"] == "tiny-v1" and record["digest"] == tiny.digest()
    assert main(["benchmark", "--task", "tiny", "--cycles", "udds", "--out", str(tmp_path / "no")]) != 0
    assert "drop --cycles and --scenarios" in capsys.readouterr().err


THERMAL_TASKS = ("udds-weak-loop-v2", "udds-hilly-weak-loop-v2", "udds-hilly-evening-v2", "udds-hilly-fan-failed-v2")


@pytest.mark.parametrize("task_id", THERMAL_TASKS)
def test_a_thermal_task_measures_thermal_management(task_id):
    """Physics v2's thermal tasks (docs/tasks.md, *Where heat binds*), against the stored optimum's frontier: knowing
    the heat pays (the thermal-blind plan driven on the thermal physics ≥ 1.01), the thermal ECMS is no dearer than
    the blind one, no strategy is more than 0.1 % below the optimum, and the spinning motor alone (u = 0) is never cut
    off and stays below the release, while the blind controllers are cut off."""
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation import run_strategy
    from hev_thermal_env.evaluation.references import load_reference
    from hev_thermal_env.evaluation.score import Frontier, frontier_ratio

    task = get_task(task_id)
    episode = load_reference(task)["episodes"][0]
    frontier = Frontier.from_settings({"frontier": episode["frontier"]})
    runs, ratio = {}, {}
    for name in ("engine_only", "ecms", "ecms_thermal", "dp"):
        runs[name] = run_strategy(get_strategy(name), task.cycles[0], task.scenario, physics=task.physics).summary
        ratio[name] = frontier_ratio(runs[name]["cost_g"], runs[name]["soc_final"], frontier)[0]
    assert ratio["dp"] >= 1.01 and ratio["ecms_thermal"] <= ratio["ecms"]
    assert min(ratio.values()) >= 0.999
    assert runs["dp"]["cutoff_s"] > 0 and runs["ecms"]["cutoff_s"] >= max(runs["ecms_thermal"]["cutoff_s"], 1.0)
    assert episode["optimum"]["safety_cost_s"] >= 0.0 and load_reference(task)["safety_budget_s"] >= 10.0
    release = paper_bus(physics=task.physics).thermal.cutoff_release_temp_c
    assert runs["engine_only"]["cutoff_s"] == 0 and runs["engine_only"]["max_motor_temp_c"] < release


def test_the_thermal_tasks_are_the_candidates_the_search_found():
    """Each thermal task's scenario (conditions and road) is a candidate ``benchmarks/thermal_tasks.py`` found to be a
    thermal task, and every candidate it found is a task (both build their conditions from ``in_service``)."""
    search = json.loads((ROOT / "benchmarks" / "results" / "thermal_tasks_v2.json").read_text())
    found = sorted((c["scenario"] == "hilly", json.dumps(c["conditions"], sort_keys=True))
                   for c in search["candidates"] if c["thermal_task"])
    tasks = sorted((get_scenario(get_task(t).scenario).grade_profile is not None,
                    json.dumps(dataclasses.asdict(get_scenario(get_task(t).scenario).conditions), sort_keys=True))
                   for t in THERMAL_TASKS)
    assert found == tasks and len(found) == 4
