"""Reference values of the named tasks: what a result on a task is scored against, stored in the package.

Per episode of a task (:meth:`hev_thermal_env.tasks.Task.resets`), a reference holds the thermal optimum's run
(``dp_thermal``: its cost, final SOC, episode safety cost and its frontier, the cost against the final SOC) and
:data:`~.score.ANCHOR`'s (its cost, final SOC and frontier ratio ``r0``, the normalised score's 0). With them a
result is scored without running the optimum again: :func:`episode_score` takes an episode's cost and final SOC.

The task's **safety budget** (:func:`safety_budget_s`) is fixed from the optimum's episode safety costs before any
policy is trained on the task: the largest of its episodes plus :data:`BUDGET_MARGIN`, at least
:data:`BUDGET_FLOOR_S` seconds.

A reference belongs to one physics (its fingerprint, :func:`~hev_thermal_env.physics.fingerprint.physics_fingerprint`)
and one task definition (:meth:`~hev_thermal_env.tasks.Task.digest`); :func:`load_reference` refuses a stored one
whose fingerprint or digest is not the current one (:class:`StaleReferenceError`, naming both).
``evaluate.py reference --task NAME`` recomputes and stores it (:func:`compute_reference`, :func:`save_reference`).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.physics.fingerprint import physics_fingerprint
from hev_thermal_env.tasks import Task, get_task

from .runner import RunResult, run_strategy
from .score import ANCHOR, normalised_score
from .yardstick import REFERENCE, Frontier, frontier_ratio

REFERENCE_DIR = Path(__file__).resolve().parent / "references"
"""Where the package keeps the references, one JSON file per task id."""
FORMAT = "hev-thermal-reference-v1"
BUDGET_MARGIN = 0.05
"""The safety budget is the optimum's largest episode safety cost times 1 + this ..."""
BUDGET_FLOOR_S = 10.0
"""... and at least this many seconds (the optimum often loses no capability at all)."""
ANCHOR_SOC_MARGIN = 0.01
"""The optimum's frontier reaches this far below the anchor's final SOC (:func:`frontier_halfwidth_for`)."""
BUDGET_RULE = (f"largest episode safety cost of {REFERENCE} × {1 + BUDGET_MARGIN:g}, at least {BUDGET_FLOOR_S:g} s "
               "(per episode)")


class StaleReferenceError(ValueError):
    """A stored reference measured on other physics or another task definition than the current ones."""


def reference_path(task: str | Task, directory: Path | None = None) -> Path:
    """The file of ``task``'s reference (a :class:`~hev_thermal_env.tasks.Task` or a task id) in ``directory``
    (default :data:`REFERENCE_DIR`)."""
    return Path(directory or REFERENCE_DIR) / f"{task.id if isinstance(task, Task) else task}.json"


def safety_budget_s(optimum_safety_costs_s: list[float]) -> float:
    """The task's safety budget per episode (module docstring) from the optimum's episode safety costs."""
    worst = max((float(c) for c in optimum_safety_costs_s), default=0.0)
    return round(max(worst * (1.0 + BUDGET_MARGIN), BUDGET_FLOOR_S), 3)


def frontier_halfwidth_for(soc_initial: float, anchor_soc_final: float) -> float | None:
    """The optimum's ``frontier_halfwidth`` for an episode whose anchor ends at ``anchor_soc_final``: None (the
    default, :class:`~hev_thermal_env.planning.thermal_optimum.OptimumSettings`) when the default frontier reaches
    :data:`ANCHOR_SOC_MARGIN` below it, else the half-width that does, rounded up to 0.01. Without regeneration the
    anchor can end far below the start on a long route (0.1-0.2 of SOC on generated bus routes), where no default
    frontier gives it a ratio r0."""
    from hev_thermal_env.planning.thermal_optimum import OptimumSettings

    default = OptimumSettings().frontier_halfwidth
    need = float(soc_initial) - float(anchor_soc_final) + ANCHOR_SOC_MARGIN
    if need <= default + 1e-9:
        return None
    return math.ceil(need * 100.0 - 1e-9) / 100.0


def compute_reference(task: str | Task, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run :data:`ANCHOR` and the optimum on every episode of ``task`` and return its reference record (JSON-ready);
    ``progress``: called with a line per finished episode."""
    task = get_task(task)
    if task.start_s != 0:
        raise ValueError(f"{task.id}: references are computed for episodes from second 0, not {task.start_s}")
    t0 = time.perf_counter()
    episodes = []
    for seed, options in task.resets():
        t_ep = time.perf_counter()
        anchor = run_strategy(get_strategy(ANCHOR), options["cycle"], task.scenario, seed=seed)
        width = frontier_halfwidth_for(anchor.summary["soc_initial"], anchor.summary["soc_final"])
        wide = {} if width is None else {"frontier_halfwidth": width}
        opt = run_strategy(get_strategy(REFERENCE, **wide), options["cycle"], task.scenario, seed=seed)
        episodes.append(_episode_record(options["cycle"], seed, opt, anchor, time.perf_counter() - t_ep))
        if progress is not None:
            progress(f"{task.id} {options['cycle']} seed {seed}: r0 {episodes[-1]['anchor']['frontier_ratio']}, "
                     f"optimum {episodes[-1]['optimum']['cost_g']:.1f} g in {time.perf_counter() - t_ep:.0f} s")
    budget = safety_budget_s([e["optimum"]["safety_cost_s"] for e in episodes])
    return {"format": FORMAT, "task": task.id, "task_digest": task.digest(), "physics_fingerprint":
            physics_fingerprint(), "safety_budget_s": budget, "budget_rule": BUDGET_RULE,
            "wall_s": round(time.perf_counter() - t0, 1), "episodes": episodes}


def _episode_record(cycle: str, seed: int, opt: RunResult, anchor: RunResult, wall_s: float) -> dict[str, Any]:
    settings = opt.summary.get("strategy_settings") or {}
    frontier = Frontier.from_settings(settings)
    if frontier is None:
        raise ValueError(f"{REFERENCE} published no frontier on {cycle}")
    runs = {}
    for name, res in ((REFERENCE, opt), (ANCHOR, anchor)):
        s = res.summary
        ratio, note = frontier_ratio(s["cost_g"], s["soc_final"], frontier)
        runs[name] = {"cost_g": s["cost_g"], "fuel_g": s["fuel_g"], "soc_final": s["soc_final"],
                      "frontier_ratio": ratio, "frontier_note": note, "safety_cost_s": s["safety_cost_s"],
                      "fuel_corrected_l_per_100km": s["fuel_corrected_l_per_100km"]}
    return {"cycle": cycle, "seed": int(seed), "optimum": runs[REFERENCE], "anchor": runs[ANCHOR],
            "frontier": {"soc_final": frontier.soc_final.tolist(), "cost_g": frontier.cost_g.tolist(),
                         "grid": frontier.grid, "soc_min": frontier.soc_min},
            "optimum_wall_s": round(wall_s, 1)}


def save_reference(record: dict[str, Any], directory: Path | None = None) -> Path:
    """Write ``record`` (:func:`compute_reference`) to its file; returns the path."""
    path = reference_path(record["task"], directory)
    atomic_write_json(path, record)
    return path


def load_reference(task: str | Task, directory: Path | None = None, *, check: bool = True) -> dict[str, Any]:
    """The stored reference of ``task``; ``FileNotFoundError`` without one; :class:`StaleReferenceError` (``check``)
    when its physics fingerprint or task digest is not the current one."""
    task = get_task(task)
    path = reference_path(task, directory)
    if not path.is_file():
        raise FileNotFoundError(f"no reference for {task.id} ({path}); compute it with: "
                                f"python evaluate.py reference --task {task.id}")
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: unreadable reference ({exc})") from None
    if record.get("format") != FORMAT or record.get("task") != task.id:
        raise ValueError(f"{path}: not a reference of {task.id} in format {FORMAT} (format {record.get('format')!r}, "
                         f"task {record.get('task')!r})")
    if check:
        check_current(record, task, str(path))
    return record


def check_current(record: dict[str, Any], task: Task, where: str) -> None:
    """:class:`StaleReferenceError` naming the stored and current values when ``record`` (a reference or a result
    file) was measured on other physics or another definition of ``task``."""
    fingerprint = physics_fingerprint()
    problems = []
    if record.get("physics_fingerprint") != fingerprint:
        problems.append(f"physics fingerprint {record.get('physics_fingerprint')!r} (current {fingerprint!r})")
    digest = record.get("task_digest")
    if digest is not None and digest != task.digest():
        problems.append(f"task digest {str(digest)[:16]}... (current {task.digest()[:16]}...)")
    if problems:
        raise StaleReferenceError(f"{where}: measured with {' and '.join(problems)}; recompute it with: "
                                  f"python evaluate.py reference --task {task.id}")


def episode_score(episode: dict[str, Any], cost_g: float, soc_final: float
                  ) -> tuple[float | None, float | None, str | None]:
    """``(frontier ratio, score, note)`` of a run with ``cost_g`` and ``soc_final`` on a reference ``episode``."""
    frontier = Frontier.from_settings({"frontier": episode["frontier"]})
    ratio, note = frontier_ratio(cost_g, soc_final, frontier)
    score, score_note = normalised_score(ratio, episode["anchor"]["frontier_ratio"])
    return ratio, score, note or score_note
