"""The result format (:data:`FORMAT`, JSON; docs/tasks.md, *Results of outside methods*): one method's episodes on
one task, written by this package or by any outside method.

Required: :data:`REQUIRED`; every seed of ``seeds`` (``[0]`` for a deterministic strategy) with one row per episode
of the task (``cycle``, ``env_seed``: :meth:`~hev_thermal_env.tasks.Task.resets`) holding :data:`ROW_NUMBERS`, from
the steps' infos (:class:`EpisodeTally`: ``cost_g = −Σ (reward_fuel + reward_miss + reward_overheat)``,
``safety_cost_s = Σ cost``, ``soc_final`` the last ``soc``). Optional: ``task_digest``, the row's
:data:`OPTIONAL_NUMBERS` and ``charge_sustaining``, ``description``, ``training`` (``wall_clock_s_per_seed``, one
number per seed, optionally ``timesteps`` and ``steps_per_s``) and ``track`` (:data:`TRACKS`).
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.agents.base import Strategy
from hev_thermal_env.tasks import Task, get_task

from .references import StaleReferenceError, check_current, load_reference
from .runner import run_strategy
from .score import REFERENCE

FORMAT = "hev-thermal-result-v1"
REQUIRED = ("format", "task", "physics_fingerprint", "method", "seeds", "episodes")
ROW_NUMBERS = {"cost_g": (0.0, math.inf), "soc_final": (0.0, 1.0), "safety_cost_s": (0.0, math.inf)}
#: The tracks of learned methods: ``RL`` (the env's reward alone), ``guided`` (also a strategy's actions or costs or
#: the optimum's labels: imitation, DAgger, a teacher's cost, behaviour cloning).
TRACKS = ("RL", "guided")
OPTIONAL_NUMBERS = {"fuel_g": (0.0, math.inf), "fuel_corrected_l_per_100km": (-math.inf, math.inf),
                    "soc_initial": (0.0, 1.0)}
#: A row's numbers from a run's summary (:func:`result_of_strategy`).
RUN_NUMBERS = ("cost_g", "soc_initial", "soc_final", "safety_cost_s", "fuel_g", "fuel_corrected_l_per_100km")


def track_of(config: dict[str, Any]) -> str:
    """The track of a ``train.py`` run from its config: ``guided`` when its start imitates a strategy
    (``init.imitate``, under which the refit, DAgger and the teacher's cost also live), else ``RL`` (a safety
    constraint and the reward's settings are the env's signal)."""
    return "guided" if (config.get("init") or {}).get("imitate") else "RL"


class ResultFormatError(ValueError):
    """A result file that does not follow :data:`FORMAT`; the message names the file, field and value."""


class EpisodeTally:
    """A result row added up from the env's infos: ``add(info)`` after every step, then :meth:`row`."""

    def __init__(self) -> None:
        self.cost_g = self.safety_cost_s = self.fuel_g = 0.0
        self.soc_final: float | None = None

    def add(self, info: dict[str, Any]) -> None:
        self.cost_g -= float(info["reward_fuel"]) + float(info["reward_miss"]) + float(info["reward_overheat"])
        self.safety_cost_s += float(info["cost"])
        self.fuel_g += float(info["fuel_g"])
        self.soc_final = float(info["soc"])

    def row(self, seed: int, cycle: str, env_seed: int) -> dict[str, Any]:
        return {"seed": int(seed), "cycle": cycle, "env_seed": int(env_seed), "cost_g": self.cost_g,
                "soc_final": self.soc_final, "safety_cost_s": self.safety_cost_s, "fuel_g": self.fuel_g}


def _number(value: Any, where: str, low: float, high: float) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or not low <= value <= high:
        span = f"in [{low:g}, {high:g}]" if math.isfinite(high) else f"≥ {low:g}"
        raise ResultFormatError(f"{where}: expected a finite number {span}, got {value!r}")
    return float(value)


def validate_result(data: Any, where: str = "result") -> dict[str, Any]:
    """``data`` checked against :data:`FORMAT`, the task it names and the current physics; returns it. Raises
    :class:`ResultFormatError` (or :class:`~.references.StaleReferenceError`) naming ``where``, the field and value."""
    if not isinstance(data, dict):
        raise ResultFormatError(f"{where}: expected a JSON object, got {type(data).__name__}")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise ResultFormatError(f"{where}: missing field(s) {', '.join(missing)} (required: {', '.join(REQUIRED)})")
    if data["format"] != FORMAT:
        raise ResultFormatError(f"{where}: format {data['format']!r}, expected {FORMAT!r}")
    try:
        task = get_task(data["task"])
    except ValueError as exc:
        raise ResultFormatError(f"{where}: task: {exc}") from None
    if task.id != data["task"]:
        raise ResultFormatError(f"{where}: task {data['task']!r}: name the version ({task.id})")
    if not isinstance(data["method"], str) or not data["method"].strip():
        raise ResultFormatError(f"{where}: method: expected a non-empty name, got {data['method']!r}")
    seeds = data["seeds"]
    if (not isinstance(seeds, list) or not seeds or any(isinstance(s, bool) or not isinstance(s, int) for s in seeds)
            or len(set(seeds)) != len(seeds)):
        raise ResultFormatError(f"{where}: seeds: expected a non-empty list of distinct integers, got {seeds!r}")
    if data.get("wall_clock_s") is not None:
        _number(data["wall_clock_s"], f"{where}: wall_clock_s", 0.0, math.inf)
    check_current(data, task, where)
    _check_episodes(data["episodes"], task, seeds, where)
    if data.get("training") is not None:
        _check_training(data["training"], seeds, f"{where}: training")
    if data.get("track") is not None and data["track"] not in TRACKS:
        raise ResultFormatError(f"{where}: track: expected one of {', '.join(TRACKS)}, got {data['track']!r}")
    return data


def _check_training(training: Any, seeds: list[int], where: str) -> None:
    if not isinstance(training, dict):
        raise ResultFormatError(f"{where}: expected an object, got {training!r}")
    walls = training.get("wall_clock_s_per_seed")
    if not isinstance(walls, list) or len(walls) != len(seeds):
        raise ResultFormatError(f"{where}.wall_clock_s_per_seed: expected one number per seed ({len(seeds)}), got "
                                f"{walls!r}")
    for i, w in enumerate(walls):
        _number(w, f"{where}.wall_clock_s_per_seed[{i}]", 0.0, math.inf)
    for field in ("timesteps", "steps_per_s"):
        if training.get(field) is not None:
            _number(training[field], f"{where}.{field}", 0.0, math.inf)


def _check_episodes(rows: Any, task: Task, seeds: list[int], where: str) -> None:
    if not isinstance(rows, list):
        raise ResultFormatError(f"{where}: episodes: expected a list of rows, got {type(rows).__name__}")
    expected = {(s, o["cycle"], e) for s in seeds for e, o in task.resets()}
    seen = set()
    for i, row in enumerate(rows):
        at = f"{where}: episodes[{i}]"
        if not isinstance(row, dict):
            raise ResultFormatError(f"{at}: expected an object, got {row!r}")
        key = (row.get("seed"), row.get("cycle"), row.get("env_seed", 0))
        if key not in expected:
            cycles = ", ".join(task.cycles[:3]) + ("..." if len(task.cycles) > 3 else "")
            raise ResultFormatError(f"{at}: (seed, cycle, env_seed) = {key} is not an episode of {task.id} for seeds "
                                    f"{seeds} (cycles {cycles}, env seeds {list(task.seeds)})")
        if key in seen:
            raise ResultFormatError(f"{at}: {key} appears twice")
        seen.add(key)
        for field, (low, high) in ROW_NUMBERS.items():
            if field not in row:
                raise ResultFormatError(f"{at}: missing {field}")
            _number(row[field], f"{at}.{field}", low, high)
        for field, (low, high) in OPTIONAL_NUMBERS.items():
            if row.get(field) is not None:
                _number(row[field], f"{at}.{field}", low, high)
        if row.get("charge_sustaining") is not None and not isinstance(row["charge_sustaining"], bool):
            raise ResultFormatError(f"{at}.charge_sustaining: expected true or false, got {row['charge_sustaining']!r}")
    absent = sorted(expected - seen, key=str)
    if absent:
        raise ResultFormatError(f"{where}: {len(absent)} episode(s) missing, e.g. (seed, cycle, env_seed) = "
                                f"{absent[0]}; every seed needs every episode of {task.id}")


def load_result(path: str | Path) -> dict[str, Any]:
    """Read and validate a result file (errors name the file)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise ResultFormatError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ResultFormatError(f"{path}: not JSON ({exc})") from None
    return validate_result(data, str(path))


def result_of_strategy(task: str | Task, strategy: str | Strategy, method: str | None = None, *,
                       references: Path | None = None, **options: Any) -> dict[str, Any]:
    """The result record (seed 0) of a strategy (a name, built by ``get_strategy(strategy, **options)``, or a
    :class:`~hev_thermal_env.agents.base.Strategy`) on every episode of ``task``. The optimum
    (:data:`~.score.REFERENCE`, without options) is asked for the ``frontier_halfwidth`` its episode's stored
    reference (in ``references``, default the package's) was solved with: it reuses that plan and its run is the
    reference's."""
    task = get_task(task)
    t0 = time.perf_counter()
    episodes = []  # the stored reference's, for the optimum
    if strategy == REFERENCE and not options:
        with contextlib.suppress(FileNotFoundError, StaleReferenceError):
            episodes = load_reference(task, references)["episodes"]
    widths = {(e["cycle"], int(e["seed"])): float(e["frontier_halfwidth"]) for e in episodes
              if e.get("frontier_halfwidth") is not None}
    rows = []
    for env_seed, opts in task.resets():
        width = widths.get((opts["cycle"], int(env_seed)))
        kwargs = options if width is None else {**options, "frontier_halfwidth": width}
        agent = get_strategy(strategy, **kwargs) if isinstance(strategy, str) else strategy
        s = run_strategy(agent, opts["cycle"], task.scenario, seed=env_seed, physics=task.physics).summary
        rows.append({"seed": 0, "cycle": opts["cycle"], "env_seed": int(env_seed), **{k: s[k] for k in RUN_NUMBERS},
                     "charge_sustaining": bool(s["charge_sustaining"])})
    return _record(task, method or str(getattr(strategy, "label", strategy)), [0], round(time.perf_counter() - t0, 2),
                   rows)


def _record(task: Task, method: str, seeds: list[int], wall_clock_s: float, rows: list, **more) -> dict[str, Any]:
    return {"format": FORMAT, "task": task.id, "task_digest": task.digest(), "physics_fingerprint": task.fingerprint(),
            "method": method, "seeds": seeds, "wall_clock_s": wall_clock_s, "episodes": rows, **more}


def result_of_seeds(task: str | Task, policies: dict[int, str | Strategy], method: str, *,
                    training: dict[str, Any] | None = None, track: str | None = None) -> dict[str, Any]:
    """The result record of a seed family: ``policies`` maps each training seed to a strategy (a name, e.g.
    ``ppo:PATH``, or a :class:`~hev_thermal_env.agents.base.Strategy`), each driven on every episode of ``task``;
    ``training`` and ``track``: as in the module docstring, or None."""
    task = get_task(task)
    if not policies:
        raise ValueError(f"result_of_seeds: {method}: no seeds given")
    t0 = time.perf_counter()
    rows = []
    for seed, name in policies.items():
        one = result_of_strategy(task, name, method)
        rows += [{**row, "seed": int(seed)} for row in one["episodes"]]
    more = {k: v for k, v in (("training", training), ("track", track)) if v is not None}
    return validate_result(_record(task, method, [int(s) for s in policies], round(time.perf_counter() - t0, 2), rows,
                                   **more), f"{method} on {task.id}")


def result_of_reference(task: str | Task, references: Path | None = None) -> dict[str, Any]:
    """The optimum's result record (:data:`~.score.REFERENCE`) read from ``task``'s stored reference (in
    ``references``, default the package's): its runs there, no plan solved. ``wall_clock_s`` is the plans' solve
    time recorded in the reference."""
    task = get_task(task)
    ref = load_reference(task, references)
    rows, plan_s = [], 0.0
    for e in ref["episodes"]:
        opt = e["optimum"]
        row = {"seed": 0, "cycle": e["cycle"], "env_seed": int(e["seed"]), "cost_g": opt["cost_g"],
               "soc_final": opt["soc_final"], "safety_cost_s": opt["safety_cost_s"], "fuel_g": opt.get("fuel_g"),
               "fuel_corrected_l_per_100km": opt.get("fuel_corrected_l_per_100km")}
        rows.append({k: v for k, v in row.items() if v is not None})
        plan_s += float(e.get("optimum_plan_s") or 0.0)
    return validate_result(_record(task, REFERENCE, [0], round(plan_s, 1), rows,
                                   description="the optimum's runs as the task's stored reference holds them"),
                           f"{REFERENCE} on {task.id} (stored reference)")
