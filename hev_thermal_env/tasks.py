"""The benchmark's named tasks: fixed cycles × a scenario × seeds × an episode definition, each versioned; the tasks,
why each is there and how to drive one: docs/tasks.md.

A task's id, ``NAME-vVERSION`` (``hwfet-v1``), names one definition for good: changing anything that changes the
episodes makes a new version, and the test suite pins each version's :meth:`Task.digest`. The physics is not part of
a task (results carry the physics fingerprint beside the task id). :func:`make_task` builds its env,
:meth:`Task.resets` gives the ``reset`` arguments of its episodes. A training config that names a cycle of a held-out
task (``bus-generalisation``'s test routes) is refused (:func:`held_out_cycles`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any

import gymnasium as gym
import numpy as np

from .cycles import load_cycle
from .cycles.families import VALIDATION_SEED_BASE
from .physics.config import LATEST_PHYSICS, paper_bus
from .physics.fingerprint import physics_fingerprint
from .scenarios import get_scenario

ENV_ID = "HevThermal-v2"
"""The newest env id; a task's own is :attr:`Task.env_id` (its physics version)."""
#: Families of the generalisation task's test routes, in turn (those of the validation set).
TEST_FAMILIES = ("bus_long", "bus_congested", "bus_launch", "bus_hilly", "bus_mixed", "bus_express")
#: Test route ``k`` has seed ``TEST_SEED_BASE + k``: above every training seed and 2**20 above the first validation
#: seed (the validation set uses 30).
TEST_SEED_BASE = VALIDATION_SEED_BASE + 2**20
#: Number of test routes (three per family).
TEST_SIZE = 18
#: The training families of ``train.py`` (``env.cycles`` of the hyperparameter files): a fresh route per episode.
TRAINING_FAMILIES = ("random_bus", "bus_long", "bus_congested", "bus_launch", "bus_hilly", "bus_mixed", "bus_express")
#: The env's arguments that a task fixes (:func:`make_task` refuses them).
TASK_ARGS = ("cycle", "scenario", "conditions", "config", "thermal", "random_start", "soc_offset")


@dataclasses.dataclass(frozen=True)
class Task:
    """One named, versioned benchmark task.

    ``cycles``: the cycles driven, each once per seed; ``scenario``: their conditions; ``seeds``: the env's reset seeds
    (a fixed scenario starting at a fixed second draws nothing, so one seed, 0); ``start_s``: every episode starts at
    this second of its cycle and runs to the cycle's end. ``train_cycles`` / ``train_scenario``: what a learned method
    trains on for the task (``train.py --task``; the task's own unless held out). ``physics``: the physics version its
    episodes are driven on (:attr:`env_id`), not part of :meth:`digest`.
    """

    name: str
    version: int
    description: str
    cycles: tuple[str, ...]
    scenario: str
    seeds: tuple[int, ...] = (0,)
    start_s: int = 0
    train_cycles: tuple[str, ...] | None = None
    train_scenario: str | None = None
    physics: int = LATEST_PHYSICS

    env_id = property(lambda self: f"HevThermal-v{self.physics}",
                      doc="The env the task's episodes are driven in: ``HevThermal-v{physics}``.")
    id = property(lambda self: f"{self.name}-v{self.version}", doc="``NAME-vVERSION``, e.g. ``hwfet-v1``.")
    held_out = property(lambda self: self.train_cycles is not None and not set(self.cycles) & set(self.train_cycles),
                      doc="Whether the task's cycles are a test set that training never sees.")
    training = property(lambda self: (self.train_cycles or self.cycles, self.train_scenario or self.scenario),
                      doc="The training cycles and scenario of the task (``train.py --task``).")
    n_episodes = property(lambda self: len(self.cycles) * len(self.seeds))

    def fingerprint(self) -> str:
        """The physics fingerprint of ``paper_bus(physics=self.physics)``: what the task's references and results are
        checked against."""
        return physics_fingerprint(paper_bus(physics=self.physics))

    def env_kwargs(self) -> dict[str, Any]:
        """The env's arguments that the task fixes (plain values, so that the env's spec serialises)."""
        return {"cycle": list(self.cycles) if len(self.cycles) > 1 else self.cycles[0], "scenario": self.scenario,
                "random_start": False}

    def resets(self) -> list[tuple[int, dict[str, Any]]]:
        """``(seed, options)`` of ``env.reset`` for each episode: every cycle with every seed, in order."""
        return [(seed, {"cycle": cycle, "start_s": self.start_s}) for cycle in self.cycles for seed in self.seeds]

    def to_dict(self) -> dict[str, Any]:
        """The record as JSON-ready values, with its id."""
        d = dataclasses.asdict(self)
        return {"id": self.id, **{k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}}

    def digest(self) -> str:
        """SHA-256 of what the task's episodes are: the record, every cycle's samples as the scenario drives them
        (speed and grade) and the scenario's conditions and draws."""
        h = hashlib.sha256()
        record = {k: v for k, v in self.to_dict().items() if k not in ("description", "physics")}
        scen = get_scenario(self.scenario)
        record["scenario_record"] = {"conditions": scen.conditions.to_dict(), "randomized": scen.randomized,
                                     "grade_profile": scen.grade_profile, "payload_kg_range": scen.payload_kg_range}
        h.update(json.dumps(record, sort_keys=True, default=str).encode())
        for name in self.cycles:
            cyc = scen.prepare_cycle(load_cycle(name))
            h.update(np.ascontiguousarray(cyc.speed_mps, dtype="<f8").tobytes())
            h.update(np.ascontiguousarray(cyc.grade, dtype="<f8").tobytes())
        return h.hexdigest()


def generalisation_cycles() -> tuple[str, ...]:
    """The generalisation task's test routes: ``FAMILY:SEED``, the families of :data:`TEST_FAMILIES` in turn, seeds
    ``TEST_SEED_BASE + k``."""
    return tuple(f"{TEST_FAMILIES[k % len(TEST_FAMILIES)]}:{TEST_SEED_BASE + k}" for k in range(TEST_SIZE))


_TASKS = (
    Task("hwfet", 1, "EPA highway cycle, the paper's conditions: sustained load, trace misses above 89 km/h",
         ("hwfet",), "paper", physics=1),
    Task("beijing", 1, "the synthetic Beijing-like city-bus cycle, the paper's conditions", ("beijing",), "paper",
         physics=1),
    Task("udds-hot", 1, "EPA urban cycle with a failing cooling loop (hot): the thermal constraint binds",
         ("udds",), "hot", physics=1),
    Task("hilly", 1, "UDDS over rolling hills (grades up to ±7 %, no net climb)", ("udds",), "hilly", physics=1),
    Task("full-bus", 1, "UDDS with 4.5 t of passengers (19.5 t in all)", ("udds",), "full_bus", physics=1),
    Task("summer", 1, "UDDS on a summer day (38 °C, cooling intact): every overload derates at once",
         ("udds",), "summer", physics=1),
    Task("bus-generalisation", 1, f"{TEST_SIZE} held-out generated bus routes ({TEST_SIZE // len(TEST_FAMILIES)} of "
         "each of six families, seeds never used by training or validation), the paper's conditions; trained on fresh "
         "routes of the families", generalisation_cycles(), "paper", train_cycles=TRAINING_FAMILIES,
         train_scenario="random_service", physics=1),
    Task("hwfet", 2, "EPA highway cycle, the paper's conditions: sustained load, trace misses above 89 km/h",
         ("hwfet",), "paper"),
    Task("beijing", 2, "the synthetic Beijing-like city-bus cycle, the paper's conditions", ("beijing",), "paper"),
    Task("udds-weak-loop", 2, "EPA urban cycle, a full bus an hour into service on a 40 °C day, the pump's flow at "
         "10 % (weak_loop): knowing the heat pays", ("udds",), "weak_loop"),
    Task("udds-hilly-weak-loop", 2, "UDDS over rolling hills in weak_loop's conditions (hilly_weak_loop): knowing the "
         "heat pays", ("udds",), "hilly_weak_loop"),
    Task("udds-hilly-evening", 2, "UDDS over rolling hills, a full bus late in service on a 35 °C day, the motor at "
         "58 °C, the pump's flow at 10 % (hilly_evening): knowing the heat pays", ("udds",), "hilly_evening"),
    Task("udds-hilly-fan-failed", 2, "UDDS over rolling hills, a full bus in 40 °C air, the motor at 58 °C, the "
         "radiator's fan failed and the pump's flow at 20 % (hilly_fan_failed): knowing the heat pays", ("udds",),
         "hilly_fan_failed"),
)
TASKS: dict[str, Task] = {t.id: t for t in _TASKS}
"""The tasks by id."""


def list_tasks() -> list[str]:
    """The ids of the tasks, in the documented order."""
    return list(TASKS)


def get_task(name: str | Task) -> Task:
    """A task by id (``hwfet-v1``) or by name (``hwfet``: its newest version); one-line ``ValueError`` naming the known
    ids otherwise."""
    if isinstance(name, Task):
        return name
    key = str(name).strip().lower()
    if key in TASKS:
        return TASKS[key]
    versions = [t for t in TASKS.values() if t.name == key]
    if versions:
        return max(versions, key=lambda t: t.version)
    raise ValueError(f"unknown task {name!r}; tasks: {', '.join(TASKS)} (a name alone is its newest version)")


def make_task(name: str | Task, num_envs: int | None = None, **env_kwargs: Any) -> Any:
    """The env of a task (``gymnasium.make``), or with ``num_envs`` its native vector env (``gymnasium.make_vec``);
    ``env_kwargs``: the env's other arguments (``info_keys``, ``preview_s``, ...), not those the task fixes
    (:data:`TASK_ARGS`). Drive the task's episodes with :meth:`Task.resets`."""
    task = get_task(name)
    fixed = sorted(set(env_kwargs) & set(TASK_ARGS))
    if fixed:
        raise ValueError(f"make_task({task.id!r}): {', '.join(fixed)} belong(s) to the task; make the env with "
                         f"gymnasium.make({task.env_id!r}, ...) for other settings")
    kwargs = {**task.env_kwargs(), **env_kwargs}
    return gym.make(task.env_id, **kwargs) if num_envs is None else gym.make_vec(task.env_id, num_envs, **kwargs)


def held_out_cycles() -> dict[str, str]:
    """The cycles of held-out tasks (lower case) and the id of the task each belongs to: no training run trains or
    selects checkpoints on them."""
    return {c.lower(): t.id for t in TASKS.values() if t.held_out for c in t.cycles}
