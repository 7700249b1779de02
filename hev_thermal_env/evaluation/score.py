"""The normalised score: the share of the achievable saving a strategy captures, 0 = ``engine_only``, 100 = the optimum.

Per episode, with ``r`` the strategy's frontier ratio (:mod:`.yardstick`) and ``r0`` that of :data:`ANCHOR` (the
hybrid with its motor unused) on the same episode::

    score = 100 · (r0 − r) / (r0 − 1)

The thermal optimum scores 100 (its frontier ratio is 1 up to the tolerance of its replay), ``engine_only`` 0; a
strategy worse than leaving the motor unused scores below 0. The score is never clipped. Where ``r0 − 1`` is below
:data:`ILL_CONDITIONED_BELOW` the motor can save almost nothing on the episode and the score divides by almost
nothing: it is flagged ``ill-conditioned`` and kept out of every aggregate. ``conventional`` (a bus without a motor)
is another vehicle and never an anchor.

Aggregates (:func:`aggregate`) are the interquartile mean over episodes and seeds with a 95 % stratified bootstrap
interval (:func:`hev_thermal_env.stats.stratified_iqm_ci`, one stratum per episode). See docs/metrics.md.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from hev_thermal_env.stats import stratified_iqm_ci

ANCHOR = "engine_only"
"""The strategy whose frontier ratio is the score's 0."""
ILL_CONDITIONED_BELOW = 0.02
"""``r0 − 1`` below this: the score is flagged and left out of aggregates."""
ILL_CONDITIONED = "ill-conditioned"
OPTIMUM_RATIO_TOLERANCE = 1e-3
"""The optimum's stated tolerance: no run's frontier ratio lies below 1 − this (the grid's resolution)."""
SOC_BOUND = 0.02
"""|ΔSOC| beyond which a run does not hold its charge: a checkpoint with such a validation run is not selected
(:mod:`hev_thermal_env.training.selection`), and a score counts such runs (``beyond_soc_bound``)."""


def normalised_score(ratio: float | None, anchor_ratio: float | None) -> tuple[float | None, str | None]:
    """``(score, note)`` of one episode: ``note`` is None for a usable score, :data:`ILL_CONDITIONED` (with the
    value when ``r0 > 1``) when ``r0 − 1 <`` :data:`ILL_CONDITIONED_BELOW`, or says which ratio is missing."""
    if anchor_ratio is None:
        return None, f"no {ANCHOR} frontier ratio on this episode"
    if ratio is None:
        return None, "no frontier ratio"
    r0, r = float(anchor_ratio), float(ratio)
    gap = r0 - 1.0
    score = 100.0 * (r0 - r) / gap if gap > 0.0 else None
    if gap < ILL_CONDITIONED_BELOW:
        return score, f"{ILL_CONDITIONED}: {ANCHOR}'s frontier ratio is {r0:.4f} (r0 − 1 < {ILL_CONDITIONED_BELOW})"
    return score, None


def score_tolerance(anchor_ratio: float) -> float:
    """How far above 100 a score may lie within :data:`OPTIMUM_RATIO_TOLERANCE`, on an episode with ``r0``."""
    return 100.0 * OPTIMUM_RATIO_TOLERANCE / (float(anchor_ratio) - 1.0)


def usable(score: float | None, note: str | None) -> bool:
    """Whether an episode's score enters aggregates."""
    return score is not None and not (note or "").startswith(ILL_CONDITIONED)


def aggregate(groups: Sequence[Sequence[tuple[float | None, str | None]]]) -> dict[str, Any]:
    """IQM and 95 % interval of the usable scores of ``groups`` (one group per episode, each ``(score, note)`` of a
    seed), and how many were left out: ``{"score", "score_ci_low", "score_ci_high", "n", "excluded"}``."""
    kept = [[s for s, note in g if usable(s, note)] for g in groups]
    n = sum(len(g) for g in kept)
    total = sum(len(g) for g in groups)
    centre, low, high = stratified_iqm_ci(kept) if n else (None, None, None)
    return {"score": centre, "score_ci_low": low, "score_ci_high": high, "n": n, "excluded": total - n}


def score_text(centre: float | None, low: float | None = None, high: float | None = None) -> str:
    """``IQM [low, high]`` to one decimal; the IQM alone without an interval; "-" without a score."""
    if centre is None:
        return "-"
    if low is None or high is None or low == high == centre:
        return f"{centre:.1f}"
    return f"{centre:.1f} [{low:.1f}, {high:.1f}]"


def add_score_columns(rows: list[dict], is_family_row) -> None:
    """Fill the score's columns (``score``, ``score_ci_low``, ``score_ci_high``, ``score_anchor_ratio``,
    ``score_note``) of every row: runs against :data:`ANCHOR`'s run of their cycle and scenario; family
    rows (``is_family_row``) as the aggregate of their members' scores (cycle and scenario ``all``: over every one)."""
    anchors = {(r["cycle"], r["scenario"]): r.get("frontier_ratio") for r in rows
               if r["strategy"] == ANCHOR and r.get("family") is None}
    runs = [r for r in rows if not is_family_row(r)]
    for r in runs:
        key = (r["cycle"], r["scenario"])
        if key not in anchors:
            r["score"], r["score_note"] = None, f"{ANCHOR} did not run on this cycle and scenario"
            r["score_anchor_ratio"] = None
        else:
            r["score_anchor_ratio"] = anchors[key]
            r["score"], r["score_note"] = normalised_score(r.get("frontier_ratio"), anchors[key])
        r["score_ci_low"] = r["score_ci_high"] = None
    for f in (r for r in rows if is_family_row(r)):
        members = [m for m in runs if m.get("family") == f["family"]
                   and (f["cycle"] == "all" or (m["cycle"], m["scenario"]) == (f["cycle"], f["scenario"]))]
        agg = aggregate(list(_by_episode(members).values()))
        f.update({k: agg[k] for k in ("score", "score_ci_low", "score_ci_high")})
        f["score_anchor_ratio"] = None
        f["score_note"] = (f"{agg['excluded']} of {agg['n'] + agg['excluded']} runs left out (ill-conditioned or "
                           "without a ratio)") if agg["excluded"] else None


def _by_episode(rows: Iterable[dict]) -> dict[tuple[str, str], list[tuple[float | None, str | None]]]:
    groups: dict[tuple[str, str], list[tuple[float | None, str | None]]] = {}
    for r in rows:
        groups.setdefault((r["cycle"], r["scenario"]), []).append((r.get("score"), r.get("score_note")))
    return groups


def strategy_aggregates(rows: Sequence[dict], is_family_row) -> list[dict]:
    """Per strategy (runs, not family members), the aggregate score over every cycle × scenario it ran on, in the
    rows' order: ``{"strategy", "episodes", **aggregate}``."""
    out = []
    runs = [r for r in rows if r.get("family") is None and not is_family_row(r)]
    for name in dict.fromkeys(r["strategy"] for r in runs):
        groups = _by_episode(r for r in runs if r["strategy"] == name)
        out.append({"strategy": name, "episodes": len(groups), **aggregate(list(groups.values()))})
    return out
