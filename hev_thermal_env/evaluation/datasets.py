"""Offline datasets in Minari's format (docs/tasks.md, *Offline datasets*): a strategy's episodes on a task or on
training routes, with each episode's reset arguments in the card (``hev_thermal_episodes``), which replay needs. The
datasets live in ``$MINARI_DATASETS_PATH`` (Minari's default ``~/.minari/datasets``; ``root`` sets it).
"""

from __future__ import annotations

import os
import time
import warnings
from importlib import metadata
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles.families import TRAINING_SEED_LIMIT
from hev_thermal_env.physics.fingerprint import physics_fingerprint
from hev_thermal_env.tasks import ENV_ID, TRAINING_FAMILIES, get_task, held_out_cycles

#: Dataset sources: the strategy each drives with (``random``: uniform actions from a seeded generator).
SOURCES = {"optimum": "dp_thermal", "ecms": "ecms", "rule": "rule", "engine_only": "engine_only", "ppo": "ppo",
           "random": None}
NAMESPACE = "hev-thermal"
#: Training routes of :func:`training_routes` take family seeds from here up (below the training seed limit).
TRAINING_ROUTE_SEED_BASE = 1_000_000


def code_permalink() -> str:
    """The code that wrote a dataset: this module in the installed version of the package (the project publishes no
    repository address)."""
    try:
        version = metadata.version("hev-thermal-env")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return f"hev-thermal-env {version}: hev_thermal_env/evaluation/datasets.py (evaluate.py dataset)"


def dataset_id(source: str, task: str | None = None, scenario: str = "paper") -> str:
    """``hev-thermal/<task id>/<source>-v0`` or, without a task, ``hev-thermal/train-<scenario>/<source>-v0``."""
    where = get_task(task).id if task is not None else f"train-{scenario}"
    return f"{NAMESPACE}/{where}/{source}-v0"


def training_routes(n: int, families: tuple[str, ...] | None = None) -> list[str]:
    """``n`` generated routes of the training ``families`` in turn (default: those of
    :data:`~hev_thermal_env.tasks.TRAINING_FAMILIES` but ``random_bus``), ``FAMILY:SEED`` with seeds from
    :data:`TRAINING_ROUTE_SEED_BASE`: below the training seed limit, so no test or validation cycle."""
    families = tuple(families or (f for f in TRAINING_FAMILIES if f != "random_bus"))
    unknown = sorted(set(families) - set(TRAINING_FAMILIES))
    if unknown:
        raise ValueError(f"{unknown} are not training families ({', '.join(TRAINING_FAMILIES)})")
    if TRAINING_ROUTE_SEED_BASE + n >= TRAINING_SEED_LIMIT:
        raise ValueError(f"{n} routes reach past the training seed limit {TRAINING_SEED_LIMIT}")
    return [f"{families[k % len(families)]}:{TRAINING_ROUTE_SEED_BASE + k}" for k in range(n)]


def _act_fn(source: str, seed: int):
    """(reset(env), act(obs, info), the env arguments it drives with) of a source."""
    if source not in SOURCES:
        raise ValueError(f"unknown dataset source {source!r}; sources: {', '.join(SOURCES)}")
    if SOURCES[source] is None:
        space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        space.seed(int(seed))
        return (lambda env: None), (lambda obs, info: space.sample()), {}
    strategy = get_strategy(SOURCES[source])
    return strategy.reset, strategy.act, strategy.env_options()


def write_dataset(source: str, *, task: str | None = None, routes: list[str] | None = None, scenario: str = "paper",
                  root: str | Path | None = None, seed: int = 0, dataset_name: str | None = None) -> dict[str, Any]:
    """Write the dataset of ``source`` on every episode of ``task``, or on ``routes`` in ``scenario`` (seed 0 each);
    returns ``{"dataset_id", "path", "episodes", "steps", "bytes", "wall_s"}``."""
    import minari

    if (task is None) == (routes is None):
        raise ValueError("write_dataset: give a task or training routes, not both")
    if root is not None:
        os.environ["MINARI_DATASETS_PATH"] = str(Path(root).resolve())
    if task is not None:
        t = get_task(task)
        resets = [(s, dict(o)) for s, o in t.resets()]
        env_kwargs, meta = t.env_kwargs(), {"hev_thermal_task": t.id, "hev_thermal_task_digest": t.digest()}
        env_id, fingerprint = t.env_id, t.fingerprint()
    else:
        held = sorted(set(r.lower() for r in routes) & set(held_out_cycles()))
        if held:
            raise ValueError(f"routes {held} belong to held-out tasks; datasets for training use training routes")
        resets = [(0, {"cycle": r, "start_s": 0}) for r in routes]
        env_kwargs = {"cycle": list(routes), "scenario": scenario, "random_start": False}
        meta = {"hev_thermal_task": None, "hev_thermal_routes": list(routes), "hev_thermal_scenario": scenario}
        env_id, fingerprint = ENV_ID, physics_fingerprint()
    name = dataset_name or dataset_id(source, task, scenario)
    t0 = time.perf_counter()
    reset, act, source_options = _act_fn(source, seed)
    env = minari.DataCollector(gym.make(env_id, **env_kwargs, **source_options), record_infos=True,
                               data_format="arrow")
    steps = 0
    for env_seed, options in resets:
        obs, info = env.reset(seed=int(env_seed), options=options)
        reset(env)
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(np.asarray(act(obs, info), dtype=np.float32).reshape(1))
            steps += 1
            done = terminated or truncated
    algorithm = f"hev_thermal_env strategy {SOURCES[source] or source}"
    where = meta.get("hev_thermal_task") or f"training routes {', '.join(meta['hev_thermal_routes'])}"
    description = (f"{len(resets)} episodes ({steps} steps) of {source} on {where}; physics fingerprint {fingerprint}. "
                   "Replay: reset with each entry of metadata['hev_thermal_episodes'].")
    with warnings.catch_warnings():  # the project publishes no contact address
        warnings.filterwarnings("ignore", message=".*author_email.*")
        dataset = env.create_dataset(dataset_id=name, eval_env=env.spec, algorithm_name=algorithm,
                                     code_permalink=code_permalink(), author="hev-thermal-env", description=description)
    dataset.storage.update_metadata({**meta, "hev_thermal_physics_fingerprint": fingerprint,
                                     "hev_thermal_source": source, "hev_thermal_episodes": [
                                         {"seed": int(s), "cycle": o["cycle"], "start_s": int(o["start_s"])}
                                         for s, o in resets]})
    env.close()
    path = Path(dataset.storage.data_path).parent
    size = sum(p.stat().st_size for p in path.rglob("*") if p.is_file())
    return {"dataset_id": name, "path": str(path), "episodes": len(resets), "steps": steps, "bytes": size,
            "wall_s": round(time.perf_counter() - t0, 1)}
