"""Reference values of the named tasks, stored in the package (docs/tasks.md, *Reference values*): per episode the
thermal optimum's run and :data:`~.score.ANCHOR`'s, so a result is scored without running the optimum again
(:func:`episode_score`), and the task's safety budget (:func:`safety_budget_s`). A reference belongs to one physics
fingerprint and one task digest; :func:`load_reference` refuses a stale one (:class:`StaleReferenceError`).
``evaluate.py reference`` recomputes it.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import load_cycle
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.tasks import Task, get_task, list_tasks

from .executors import LocalExecutor
from .runner import run_strategy
from .score import ANCHOR, REFERENCE, Frontier, frontier_ratio, normalised_score

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


def reference_path(task_id: str, directory: Path | None = None) -> Path:
    """The file of the reference of the task ``task_id`` in ``directory`` (default :data:`REFERENCE_DIR`)."""
    return Path(directory or REFERENCE_DIR) / f"{task_id}.json"


def safety_budget_s(optimum_safety_costs_s: list[float]) -> float:
    """The task's safety budget per episode from the optimum's episode safety costs: the largest times
    1 + :data:`BUDGET_MARGIN`, at least :data:`BUDGET_FLOOR_S`."""
    worst = max((float(c) for c in optimum_safety_costs_s), default=0.0)
    return round(max(worst * (1.0 + BUDGET_MARGIN), BUDGET_FLOOR_S), 3)


def frontier_halfwidth_for(soc_initial: float, anchor_soc_final: float) -> float | None:
    """The optimum's ``frontier_halfwidth`` for an episode whose anchor ends at ``anchor_soc_final``: None (the
    default) when the default frontier reaches :data:`ANCHOR_SOC_MARGIN` below it, else the half-width that does,
    rounded up to 0.01 (the anchor can end 0.1-0.2 of SOC below the start on a long generated bus route)."""
    from hev_thermal_env.planning.thermal_optimum import OptimumSettings

    default = OptimumSettings().frontier_halfwidth
    need = float(soc_initial) - float(anchor_soc_final) + ANCHOR_SOC_MARGIN
    if need <= default + 1e-9:
        return None
    return math.ceil(need * 100.0 - 1e-9) / 100.0


def compute_reference(task: str | Task, progress: Callable[[str], None] | None = None,
                      jobs: int = 1) -> dict[str, Any]:
    """Run :data:`ANCHOR` and the optimum on every episode of ``task``; its reference record (JSON-ready).
    ``progress``: called with a line per finished episode; ``jobs``: episodes solved at once, each in its own process
    with one thread (longest route first; only the record's times depend on it)."""
    task = get_task(task)
    if task.start_s != 0:
        raise ValueError(f"{task.id}: references are computed for episodes from second 0, not {task.start_s}")
    t0 = time.perf_counter()
    threads = 1 if jobs > 1 else None
    cells = [(options["cycle"], seed, task.scenario, threads, task.physics) for seed, options in task.resets()]
    order = list(range(len(cells)))
    if jobs > 1:
        order.sort(key=lambda i: -load_cycle(cells[i][0]).n_steps)
    episodes: list[dict[str, Any] | None] = [None] * len(cells)
    with LocalExecutor(jobs) as runner:
        for item in runner.map(reference_episode, cells, order, tick_s=1.0):
            if item is None:
                continue
            i, episodes[i] = item
            if progress is not None:
                e = episodes[i]
                plan = "plan read from disk" if e["plan_from_cache"] else "plan solved"
                progress(f"{task.id} {e['cycle']} seed {e['seed']}: r0 {e['anchor']['frontier_ratio']}, "
                         f"optimum {e['optimum']['cost_g']:.1f} g in {e['optimum_wall_s']:.0f} s ({plan}; it took "
                         f"{e['optimum_plan_s']} s to solve)")
    budget = safety_budget_s([e["optimum"]["safety_cost_s"] for e in episodes])
    return {"format": FORMAT, "task": task.id, "task_digest": task.digest(), "physics_fingerprint":
            task.fingerprint(), "safety_budget_s": budget, "budget_rule": BUDGET_RULE,
            "wall_s": round(time.perf_counter() - t0, 1), "jobs": int(jobs), "episodes": episodes}


def reference_episode(cell: tuple[str, int, str, int | None, int]) -> dict[str, Any]:
    """One episode's reference record: ``cell`` = (cycle, seed, scenario, the optimum's threads or None, physics)."""
    cycle, seed, scenario, threads, physics = cell
    t_ep = time.perf_counter()
    anchor = run_strategy(get_strategy(ANCHOR), cycle, scenario, seed=seed, physics=physics)
    width = frontier_halfwidth_for(anchor.summary["soc_initial"], anchor.summary["soc_final"])
    options = {k: v for k, v in (("frontier_halfwidth", width), ("threads", threads)) if v is not None}
    opt = run_strategy(get_strategy(REFERENCE, **options), cycle, scenario, seed=seed, physics=physics)
    wall_s = time.perf_counter() - t_ep
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
    plan_s = settings.get("plan_total_s")
    return {"cycle": cycle, "seed": int(seed), "optimum": runs[REFERENCE], "anchor": runs[ANCHOR],
            "frontier": {"soc_final": frontier.soc_final.tolist(), "cost_g": frontier.cost_g.tolist(),
                         "grid": frontier.grid, "soc_min": frontier.soc_min},
            "frontier_halfwidth": settings.get("frontier_halfwidth"),
            # the plan's own solve time, also when this run read it from disk (then optimum_wall_s is small)
            "optimum_plan_s": None if plan_s is None else round(float(plan_s), 1),
            "plan_from_cache": bool(settings.get("from_cache", False)),
            "optimum_wall_s": round(wall_s, 1)}


def save_reference(record: dict[str, Any], directory: Path | None = None) -> Path:
    """Write ``record`` (:func:`compute_reference`) to its file; returns the path."""
    return atomic_write_json(reference_path(record["task"], directory), record)


def load_reference(task: str | Task, directory: Path | None = None) -> dict[str, Any]:
    """The stored reference of ``task``; ``FileNotFoundError`` without one, :class:`StaleReferenceError` when
    stale."""
    task = get_task(task)
    path = reference_path(task.id, directory)
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
    check_current(record, task, str(path))
    return record


def check_current(record: dict[str, Any], task: Task, where: str) -> None:
    """:class:`StaleReferenceError` when ``record`` (a reference or a result) was measured on other physics or
    another definition of ``task``."""
    fingerprint = task.fingerprint()
    problems = []
    if record.get("physics_fingerprint") != fingerprint:
        problems.append(f"physics fingerprint {record.get('physics_fingerprint')!r} (current {fingerprint!r})")
    digest = record.get("task_digest")
    if digest is not None and digest != task.digest():
        problems.append(f"task digest {str(digest)[:16]}... (current {task.digest()[:16]}...)")
    if problems:
        raise StaleReferenceError(f"{where}: measured with {' and '.join(problems)}; recompute it with: "
                                  f"python evaluate.py reference --task {task.id}")


TABLE_BEGIN, TABLE_END = "<!-- references:begin -->", "<!-- references:end -->"
"""The markers between which :func:`write_references_table` puts the table in a Markdown file."""


def references_table(tasks: list[str] | None = None, directory: Path | None = None) -> str:
    """A Markdown table of the stored references of ``tasks`` (default: every named task)."""
    def span(xs: list[float], digits: int) -> str:
        return " to ".join(dict.fromkeys(f"{x:,.{digits}f}" for x in (min(xs), max(xs))))

    lines = ["| task | episodes | r0 (`engine_only`) | optimum's cost g | optimum's safety cost s | safety budget s |",
             "|---|---:|---:|---:|---:|---:|"]
    for name in tasks or list_tasks():
        task = get_task(name)
        try:
            ref = load_reference(task, directory)
        except (FileNotFoundError, StaleReferenceError) as exc:
            why = "not yet computed" if isinstance(exc, FileNotFoundError) else "stale: recompute"
            lines.append(f"| `{task.id}` | {len(task.resets())} | {why} | | | |")
            continue
        e = ref["episodes"]
        r0 = [x["anchor"]["frontier_ratio"] for x in e if x["anchor"]["frontier_ratio"] is not None]
        lines.append(f"| `{task.id}` | {len(e)} | {span(r0, 3) if r0 else 'none'} | "
                     f"{span([x['optimum']['cost_g'] for x in e], 0)} | "
                     f"{span([x['optimum']['safety_cost_s'] for x in e], 1)} | {ref['safety_budget_s']:g} |")
    return "\n".join(lines) + "\n"


def write_references_table(path: Path, table: str) -> None:
    """Put ``table`` between :data:`TABLE_BEGIN` and :data:`TABLE_END` in the Markdown file ``path``."""
    text = Path(path).read_text()
    if text.count(TABLE_BEGIN) != 1 or text.count(TABLE_END) != 1 or text.index(TABLE_BEGIN) > text.index(TABLE_END):
        raise ValueError(f"{path}: needs one line {TABLE_BEGIN} and, after it, one line {TABLE_END}")
    head, rest = text.split(TABLE_BEGIN)
    Path(path).write_text(head + TABLE_BEGIN + "\n" + table + TABLE_END + rest.split(TABLE_END, 1)[1])


def episode_score(episode: dict[str, Any], cost_g: float, soc_final: float
                  ) -> tuple[float | None, float | None, str | None]:
    """``(frontier ratio, score, note)`` of a run with ``cost_g`` and ``soc_final`` on a reference ``episode``."""
    frontier = Frontier.from_settings({"frontier": episode["frontier"]})
    ratio, note = frontier_ratio(cost_g, soc_final, frontier)
    score, score_note = normalised_score(ratio, episode["anchor"]["frontier_ratio"])
    return ratio, score, note or score_note
