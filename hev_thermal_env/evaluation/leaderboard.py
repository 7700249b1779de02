"""The leaderboard (``evaluate.py leaderboard``, docs/leaderboard.md): every method on every task with references,
scored alike (:func:`score_result`) from result files (:mod:`.submission`; :func:`ensure_results` writes this
package's), on one Markdown page with rliable's performance profile (:func:`write_leaderboard`), one row per method
and track and each physics version apart.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hev_thermal_env.agents import registered, strategy_class
from hev_thermal_env.io import atomic_write_json, atomic_write_text, files_digest, read_yaml_mapping
from hev_thermal_env.stats import CONFIDENCE, iqm
from hev_thermal_env.tasks import get_task, list_tasks

from .references import REFERENCE_DIR, StaleReferenceError, episode_score, load_reference
from .score import ANCHOR, REFERENCE, SOC_BOUND, aggregate, display_name, score_text, usable
from .styles import pyplot, save_fig
from .submission import TRACKS, ResultFormatError, load_result, result_of_reference, result_of_strategy, track_of

METHODS = tuple(cls.name for cls in registered() if cls.in_benchmark and not cls.other_vehicle)
"""The package's methods on the leaderboard, in its order: the benchmark's strategies that drive this bus (``ppo``: the
shipped policy)."""
SAFETY_MARGIN = 1.05
"""A run whose safety cost exceeds this times the optimum's on its episode, where the optimum's is not zero, counts in
``above_optimum_safety``: it derated its motor more than the optimum needed."""
PROFILE_FILE = "leaderboard_profile.png"
ZOOM = (80.0, 101.0)
"""The profile's second panel: the scores where the better strategies differ."""


def label(method: str) -> str:
    """A method's name on the page."""
    cls = strategy_class(method)
    return cls.leaderboard_label if cls is not None and cls.leaderboard_label and method == cls.name \
        else display_name(method)


def shipped_policy_digest() -> str:
    """A digest of the shipped policy's files (``ppo``): its stored result is stale once the policy is retrained."""
    from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR

    return files_digest(DEFAULT_POLICY_DIR / "model.zip", DEFAULT_POLICY_DIR / "vecnormalize.pkl")


def shipped_policy_config() -> dict[str, Any]:
    """The shipped policy's training config (``config.yaml`` beside its model): its track and physics fingerprint."""
    from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR

    return read_yaml_mapping(DEFAULT_POLICY_DIR / "config.yaml")


def ensure_results(directory: Path, tasks: Sequence[str], methods: Sequence[str] = METHODS,
                   progress: Callable[[str], None] | None = None, references: Path | None = None) -> list[Path]:
    """``DIRECTORY/<task id>/<method>.json`` for every task and method, reused when it validates (the shipped policy's
    while its files are the same), else written (the optimum's from the task's stored reference in ``references``:
    no plan solved); returns the paths. The shipped policy (``ppo``) runs only on the physics it was trained on."""
    paths = []
    shipped = shipped_policy_config() if "ppo" in methods else {}
    trained_on = (shipped.get("versions") or {}).get("physics_fingerprint")
    for name in tasks:
        task = get_task(name)
        for method in methods:
            if method == "ppo" and trained_on is not None and task.fingerprint() != trained_on:
                continue
            path = Path(directory) / task.id / f"{method}.json"
            stamp = {"policy_digest": shipped_policy_digest(), "track": track_of(shipped)} if method == "ppo" else {}
            try:
                stored = load_result(path)
                stale = any(stored.get(k) != v for k, v in stamp.items())
            except (ResultFormatError, StaleReferenceError):
                stale = True
            if stale:
                record = (result_of_reference(task, references) if method == REFERENCE
                          else result_of_strategy(task, method, references=references)) | stamp
                atomic_write_json(path, record)
                if progress is not None:
                    how = ("from the stored reference" if method == REFERENCE
                           else f"{record['wall_clock_s']:.1f} s")
                    progress(f"{task.id} {method}: {len(record['episodes'])} episodes, {how}")
            paths.append(path)
    return paths


def result_files(paths: Sequence[str | Path]) -> list[Path]:
    """The result files of ``paths``: files as given, directories searched for ``*.json`` (recursively, sorted)."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            out += sorted(q for q in p.rglob("*.json") if q.is_file())
        elif p.is_file():
            out.append(p)
        else:
            raise FileNotFoundError(f"{p}: no such result file or directory")
    return out


def score_result(result: dict[str, Any], reference: dict[str, Any]) -> dict[str, Any]:
    """The leaderboard entry of one result on its task (the IQM with its 95 % stratified bootstrap interval, one stratum
    per episode: docs/leaderboard.md); ``rows``: each episode row's frontier ratio, score and note;
    ``above_optimum_safety``: the runs that derate their motor more than :data:`SAFETY_MARGIN` × the optimum on their
    episode; ``beyond_soc_bound``: the runs whose |ΔSOC| exceeds :data:`SOC_BOUND` (None if a row lacks its
    ``soc_initial``)."""
    refs = {(e["cycle"], e["seed"]): e for e in reference["episodes"]}
    budget = float(reference["safety_budget_s"])
    groups: dict[tuple[str, int], list[tuple[float | None, str | None]]] = {}
    safety, rows = [], []
    above = beyond_soc = 0
    for row in result["episodes"]:
        key = (row["cycle"], int(row.get("env_seed", 0)))
        ratio, score, note = episode_score(refs[key], row["cost_g"], row["soc_final"])
        groups.setdefault(key, []).append((score, note))
        rows.append({"frontier_ratio": ratio, "score": score, "note": note})
        safety.append(float(row["safety_cost_s"]))
        optimum_s = float(refs[key]["optimum"]["safety_cost_s"])
        above += optimum_s > 0.0 and float(row["safety_cost_s"]) > SAFETY_MARGIN * optimum_s
        if beyond_soc is not None and row.get("soc_initial") is not None:
            beyond_soc += abs(float(row["soc_final"]) - float(row["soc_initial"])) > SOC_BOUND
        else:  # a row without its start: the count is unknown
            beyond_soc = None
    kept = [[s for s, note in g if usable(s, note)] for g in groups.values()]
    cs = [r.get("charge_sustaining") for r in result["episodes"]]
    return {"task": result["task"], "method": result["method"], "track": result.get("track"),
            "seeds": len(result["seeds"]), "runs": len(result["episodes"]), **aggregate(list(groups.values())),
            "anchor_ratios": [e["anchor"]["frontier_ratio"] for e in reference["episodes"]],
            "scores": [s for g in kept for s in g], "score_groups": kept,
            "frontier_ratio": _iqm(r["frontier_ratio"] for r in rows),
            "safety_cost_s": iqm(safety), "safety_cost_max_s": max(safety), "budget_s": budget,
            "within_budget": sum(s <= budget for s in safety), "above_optimum_safety": int(above),
            "beyond_soc_bound": beyond_soc,
            "fuel_corrected_l_per_100km": _iqm(r.get("fuel_corrected_l_per_100km") for r in result["episodes"]),
            "fuel_kg": float(np.mean([r.get("fuel_g", np.nan) for r in result["episodes"]])) / 1000.0,
            "charge_sustaining": None if any(c is None for c in cs) else sum(cs),
            "wall_clock_s": result.get("wall_clock_s"), "rows": rows,
            "training_wall_s": float(np.mean(result["training"]["wall_clock_s_per_seed"]))
            if result.get("training") else None}


def _iqm(values: Iterable[float | None]) -> float | None:
    """The IQM of the values that are not None; None without any."""
    kept = [v for v in values if v is not None]
    return iqm(kept) if kept else None


def score_files(paths: Sequence[str | Path], references_dir: Path | None = None) -> tuple[list[dict], list[str]]:
    """Entries of every result file in ``paths`` (:func:`result_files`) and the tasks without a current reference
    (their results left out, each named once with why)."""
    entries, missing, refs = [], {}, {}
    for path in result_files(paths):
        result = load_result(path)
        task = result["task"]
        if task not in refs and task not in missing:
            try:
                refs[task] = load_reference(task, references_dir)
            except (FileNotFoundError, StaleReferenceError) as exc:
                missing[task] = missing_text(task, exc)
        if task in refs:
            entries.append(score_result(result, refs[task]))
    return entries, list(missing.values())


def missing_text(task: str, exc: Exception) -> str:
    """Why a task is not on the page, without this machine's paths."""
    if isinstance(exc, FileNotFoundError):
        return f"{task}: no stored reference (compute it with `python evaluate.py reference --task {task}`)"
    return f"{task}: " + str(exc).replace(str(REFERENCE_DIR) + "/", "")


def row_key(entry: dict) -> tuple[str, str]:
    """A row of the page: one method on one track, ``RL`` or ``guided`` as its result states it, ``-`` for a package
    method that does not learn, ``unstated`` for another result that does not say."""
    return entry["method"], entry.get("track") or ("-" if entry["method"] in METHODS else "unstated")


def _order(keys: Sequence[tuple[str, str]]) -> list[tuple[str, str]]:
    """The package's methods in :data:`METHODS` order, then the RL track, the guided track and the rest, each by
    name."""
    keys = list(dict.fromkeys(keys))
    rank = {t: i for i, t in enumerate((*TRACKS, "unstated"))}
    known = sorted((k for k in keys if k[0] in METHODS), key=lambda k: METHODS.index(k[0]))
    return known + sorted((k for k in keys if k[0] not in METHODS), key=lambda k: (rank.get(k[1], len(rank)), k[0]))


def _task_table(entries: list[dict]) -> list[str]:
    e0 = entries[0]
    r0 = [r for r in e0["anchor_ratios"] if r is not None]
    r0_text = (f"`engine_only`'s frontier ratio r0 = {min(r0):.3f}" + (f" to {max(r0):.3f}" if len(r0) > 1 else "") +
               f": the motor can save {100 * (1 - 1 / max(r0)):.1f} % of its cost at equal charge" +
               (" at most" if len(r0) > 1 else "") + ". ") if r0 else ""
    lines = [f"### {e0['task']}", "", f"{r0_text}Safety budget {e0['budget_s']:g} s per episode.", "",
             "| method | track | score IQM [95 % CI] | frontier ratio | safety cost s (IQM; worst) | within budget | "
             "above the optimum's | corrected L/100 km | fuel kg | J1711 | runs |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    by_row = {row_key(e): e for e in entries}
    for key in _order(list(by_row)):
        e = by_row[key]
        cs = "-" if e["charge_sustaining"] is None else f"{e['charge_sustaining']}/{e['runs']}"
        excl = f" ({e['excluded']} left out)" if e["excluded"] else ""
        lines.append(f"| {label(key[0])} | {key[1]} | "
                     f"{score_text(e['score'], e['score_ci_low'], e['score_ci_high'])}{excl} | "
                     f"{_num(e['frontier_ratio'], 3)} | {e['safety_cost_s']:.0f}; {e['safety_cost_max_s']:.0f} | "
                     f"{e['within_budget']}/{e['runs']} | {e['above_optimum_safety']}/{e['runs']} | "
                     f"{_num(e['fuel_corrected_l_per_100km'], 2)} | {_num(e['fuel_kg'], 2)} | {cs} | {e['runs']} |")
    return lines + [""]


def _num(v: float | None, digits: int) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{v:.{digits}f}"


def overall(entries: list[dict]) -> list[dict]:
    """Per row (method and track), the score over every task it has a result on (one stratum per task and episode,
    its seeds within)."""
    out = []
    for key in _order([row_key(e) for e in entries]):
        mine = [e for e in entries if row_key(e) == key]
        groups = [[(s, None) for s in g] for e in mine for g in e["score_groups"]]
        walls = [e["training_wall_s"] for e in mine if e.get("training_wall_s") is not None]
        out.append({"method": key[0], "track": key[1], "tasks": len(mine), **aggregate(groups),
                    "left_out": sum(e["excluded"] for e in mine), "training_wall_s": max(walls) if walls else None})
    return out


def physics_groups(entries: list[dict]) -> list[tuple[str, list[dict]]]:
    """The entries by the physics they were measured on (``HevThermal-vN``, fingerprint), the newest first: scores on
    different physics are never aggregated together."""
    groups: dict[tuple[int, str], list[dict]] = {}
    for e in entries:
        task = get_task(e["task"])
        groups.setdefault((task.physics, task.fingerprint()), []).append(e)
    return [(f"physics v{v} (`HevThermal-v{v}`, fingerprint `{fp}`)", groups[(v, fp)])
            for v, fp in sorted(groups, reverse=True)]


def markdown(entries: list[dict], missing: Sequence[str], profile: str | None) -> str:
    """The leaderboard page: per physics version (:func:`physics_groups`) the table over every task and the tables
    per task; one performance profile with a panel row per physics version."""
    order = {t: i for i, t in enumerate(list_tasks())}
    md = ["# Leaderboard", "", LEAD.format(conf=100 * CONFIDENCE), ""]
    if profile:
        md += ["## Performance profile", "", f"![performance profile]({profile})", "", PROFILE_TEXT, ""]
    for title, mine in physics_groups(entries):
        tasks = sorted({e["task"] for e in mine}, key=lambda t: (order.get(t, len(order)), t))
        md += [f"## On {title}", "", f"Tasks: {', '.join(tasks)}.", "", "### Over every task", "",
               "| method | track | tasks | score IQM [95 % CI] | runs | training per seed |",
               "|---|---|---:|---:|---:|---:|"]
        for o in overall(mine):
            runs = f"{o['n']} ({o['left_out']} left out)" if o["left_out"] else str(o["n"])
            wall = "-" if o["training_wall_s"] is None else f"{o['training_wall_s'] / 60.0:.1f} min"
            md.append(f"| {label(o['method'])} | {o['track']} | {o['tasks']} | "
                      f"{score_text(o['score'], o['score_ci_low'], o['score_ci_high'])} | {runs} | {wall} |")
        md += [""]
        for t in tasks:
            md += _task_table([e for e in mine if e["task"] == t])
    if missing:
        md += ["## Tasks without references", "", *[f"* {m}" for m in missing], ""]
    md += [COMMAND]
    return "\n".join(md).rstrip() + "\n"


LEAD = ("Every method on every task that has stored references, each physics version apart (its fingerprint in its "
        "section's title and on the profile). *track*: what a learned method learns from: *RL*, the env's reward "
        "alone; *guided*, also a strategy's actions or costs or the optimum's labels (imitation, DAgger, a teacher's "
        "cost, behaviour cloning), read from its training config ([Training](training.md#two-tracks)); `-` for a "
        "method that does not learn. One row per method and track; variants of a training recipe are in the "
        "training page's [ablation table](training.md#ablations-of-the-guided-recipe). *score*: "
        "the normalised score, 0 = `engine_only` (the bus with its motor unused), 100 = the thermal optimum at "
        "equal charge, per episode 100 · (r0 − r) / (r0 − 1) with r the frontier ratio; the interquartile mean "
        "over episodes and seeds with its {conf:.0f} % stratified bootstrap interval "
        "([Metrics](metrics.md#the-normalised-score)). *safety cost*: the episode's seconds of lost motor "
        "capability (Σ `info[\"cost\"]`), against the task's budget ([Tasks](tasks.md#safety-budgets)). *above the "
        "optimum's*: runs whose safety cost exceeds the optimum's on the same episode by more than 5 %, where the "
        "optimum derates at all. *frontier ratio*: IQM of the runs' cost over the optimum's at the same final "
        "SOC. *corrected L/100 km*: fuel at equal charge and service (IQM). *fuel kg*: raw fuel per episode "
        "(mean). *J1711*: runs that are charge-sustaining. *left out*: runs without a score (a final SOC off the "
        "optimum's frontier, so no frontier ratio, or an ill-conditioned episode). The bootstrap resamples the "
        "seeds within each episode: a deterministic strategy has one run per episode, so its score has no "
        "interval. The optimum's row is the run stored with each task's reference (no plan is solved for this "
        "page). The shipped policy (`ppo`) is on the tasks of the physics it was trained on. *training per seed*: a "
        "learned method's mean wall-clock to train one seed (the result file's `training`); `-` for a method that "
        "is not trained here.")
PROFILE_TEXT = ("The fraction of a method's runs (every task, episode and seed of one physics version; a run without a "
                "score counts as below every τ) whose normalised score exceeds τ, as rliable draws it: a curve "
                "further right is better; where it drops shows the spread of the method's scores across tasks. One "
                "row of panels per physics version, its fingerprint in the row's title.")
COMMAND = ("Regenerate with `python evaluate.py leaderboard --results benchmarks/results/learned_baselines --out "
           "docs/leaderboard.md` (the learned baselines' seed families: `benchmarks/learned_baselines.py`, "
           "[Training](training.md#the-learned-baselines); add `--results FILE` for a method written elsewhere; the "
           "result format: [Tasks](tasks.md#results-of-outside-methods)).")


#: Line styles of the profile's curves, in turn once the palette's colours are used up.
STYLES = ("-", ":", "-.")


def _profile_lines(ax, scores: dict[tuple[str, str], np.ndarray], unscored: dict[tuple[str, str], int], lo: float,
                   hi: float, look: dict[tuple[str, str], dict[str, Any]]) -> None:
    for key, v in scores.items():
        total = v.size + unscored[key]  # a run without a score lies below every τ
        if v.size:
            x = np.r_[lo, v, hi]
            y = np.r_[v.size, v.size - np.arange(1, v.size + 1), 0.0] / total
            what = f"{total} runs" + (f", {unscored[key]} without a score" if unscored[key] else "")
            name = label(key[0]) if key[1] == "-" else f"{label(key[0])} [{key[1]}]"
            ax.step(x, y, where="post", label=f"{name} ({what})", **look[key])
    for x in (0.0, 100.0):
        ax.axvline(x, color="0.6", lw=0.8, zorder=0)
    ax.set(xlim=(lo, hi), ylim=(-0.02, 1.02),
           xlabel="normalised score τ (0 = engine_only, 100 = the thermal optimum)")
    ax.grid(alpha=0.3)


def _looks(keys: Sequence[tuple[str, str]], plt: Any) -> dict[tuple[str, str], dict[str, Any]]:
    """One (colour, line style) pair per row: past the palette's length the styles change, so no two curves agree."""
    palette = plt.get_cmap("tab10" if len(keys) <= 10 else "tab20").colors
    return {k: {"color": palette[i % len(palette)], "lw": 2.2 if k[0] == REFERENCE else 1.6,
                "ls": "--" if k[0] in (ANCHOR, REFERENCE) else STYLES[(i // len(palette)) % len(STYLES)]}
            for i, k in enumerate(keys)}


def profile_figure(entries: list[dict]):
    """The performance profile (the fraction of runs whose score exceeds τ, docs/leaderboard.md), one row of panels per
    physics version (:func:`physics_groups`, its fingerprint in the row's title): every row (method and track) over the
    whole range of scores (a symmetric-log axis, linear within ±100) and zoomed on :data:`ZOOM`, where the better
    strategies differ."""
    plt = pyplot()
    groups = physics_groups(entries)
    fig = plt.figure(figsize=(16.0, 5.8 * len(groups)), layout="constrained")
    subs = fig.subfigures(len(groups), 1, squeeze=False)[:, 0] if len(groups) > 1 else [fig]
    for sub, (title, mine) in zip(subs, groups):
        keys = _order([row_key(e) for e in mine])
        scores = {k: np.sort([s for e in mine if row_key(e) == k for s in e["scores"]]) for k in keys}
        unscored = {k: sum(e["excluded"] for e in mine if row_key(e) == k) for k in keys}
        axes = sub.subplots(1, 2, gridspec_kw={"width_ratios": [3, 2]})
        lowest = min([-100.0, *(float(v[0]) for v in scores.values() if v.size)])
        look = _looks(keys, plt)
        for ax, (lo, hi) in zip(axes, ((1.5 * lowest, 110.0), ZOOM)):
            _profile_lines(ax, scores, unscored, lo, hi, look)
        axes[0].set_xscale("symlog", linthresh=100.0)
        axes[0].set_ylabel("fraction of runs with score > τ")
        axes[0].set_title("every score (symmetric-log axis, linear within ±100)", fontsize=10)
        axes[1].set_title(f"zoom: τ from {ZOOM[0]:g} to {ZOOM[1]:g}", fontsize=10)
        sub.legend(*axes[0].get_legend_handles_labels(), loc="outside right upper", fontsize=8)
        tasks = len({e["task"] for e in mine})
        sub.suptitle(f"Performance profile on {title.replace('`', '')}: {tasks} task(s) with references",
                     fontsize=11)
    return fig


def write_leaderboard(entries: list[dict], missing: Sequence[str], out: Path, plot: bool = True) -> Path:
    """Write the page ``out`` and, with ``plot``, :data:`PROFILE_FILE` beside it; returns the page's path."""
    out = Path(out)
    profile = PROFILE_FILE if plot and entries else None
    if profile:
        save_fig(profile_figure(entries), out.parent / PROFILE_FILE)
    atomic_write_text(out, markdown(entries, missing, profile))
    return out
