"""The benchmark's yardstick and the normalised score: every run against the thermal optimum (``dp_thermal``);
docs/metrics.md.

The reference run publishes in its ``strategy_settings`` the optimum's cost against the final SOC,
``"frontier": {"soc_final": [...], "cost_g": [...], "grid": "<method and grid>"}`` (:class:`Frontier`);
:func:`add_yardstick_columns` gives each row ``frontier_ratio`` = ``cost_g`` / F(``soc_final``) and the other ratios.
The normalised score of an episode, with ``r`` the frontier ratio and ``r0`` that of :data:`ANCHOR`::

    score = 100 · (r0 − r) / (r0 − 1)

never clipped; where ``r0 − 1`` < :data:`ILL_CONDITIONED_BELOW` it is flagged ``ill-conditioned`` and kept out of
every aggregate (:func:`aggregate`: IQM over episodes and seeds, a 95 % bootstrap interval stratified by episode).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from hev_thermal_env.agents import strategy_class
from hev_thermal_env.stats import stratified_iqm_ci

REFERENCE = "dp_thermal"
"""The strategy whose run is the yardstick (added to every benchmark)."""
BLIND_DP = "dp"
"""The thermal-blind DP, kept as the reference of ``fuel_vs_thermal_blind_dp_pct``."""
SOC_TOLERANCE = 1e-9  # a final SOC this close to the frontier's end is on it (float round-off)
ANCHOR = "engine_only"
"""The strategy whose frontier ratio is the score's 0."""
ILL_CONDITIONED_BELOW = 0.02
"""``r0 − 1`` below this: the score is flagged and left out of aggregates."""
ILL_CONDITIONED = "ill-conditioned"
SOC_BOUND = 0.02
"""|ΔSOC| beyond which a run does not hold its charge: a checkpoint with such a validation run is not selected
(:mod:`hev_thermal_env.training.selection`), and a score counts such runs (``beyond_soc_bound``)."""


@dataclasses.dataclass(frozen=True)
class Frontier:
    """The optimum's cost (g) against the final SOC, sorted by SOC; ``grid`` names the method and grid. F(s) is the
    lowest cost of a path ending at SOC ≥ s, so below the first point it is the first point's cost, down to
    ``soc_min`` (the lowest final SOC the optimum searched; default the first point)."""

    soc_final: np.ndarray
    cost_g: np.ndarray
    grid: str
    soc_min: float

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any] | None) -> Frontier | None:
        """The frontier a reference run published in its ``strategy_settings``, None if it published none; a
        ``ValueError`` naming the problem when it is malformed (lengths differ, no points, not finite, not sorted)."""
        data = (settings or {}).get("frontier")
        if data is None:
            return None
        try:
            soc = np.asarray(data["soc_final"], dtype=float).ravel()
            cost = np.asarray(data["cost_g"], dtype=float).ravel()
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"the reference's frontier is malformed ({exc!r}): expected soc_final and cost_g "
                             "lists") from None
        if soc.size == 0 or soc.size != cost.size:
            raise ValueError(f"the reference's frontier has {soc.size} soc_final and {cost.size} cost_g values; "
                             "expected the same number, at least one")
        if not (np.all(np.isfinite(soc)) and np.all(np.isfinite(cost))):
            raise ValueError("the reference's frontier holds values that are not finite")
        if np.any(np.diff(soc) < 0.0):
            raise ValueError("the reference's frontier is not sorted by soc_final")
        soc_min = float(soc[0]) if data.get("soc_min") is None else min(float(data["soc_min"]), float(soc[0]))
        return cls(soc, cost, str(data.get("grid", "")).strip(), soc_min)

    def cost_at(self, soc_final: float) -> float | None:
        """F(``soc_final``) by linear interpolation; the first point's cost from ``soc_min`` up to it; None
        below ``soc_min`` or above the last point."""
        if not self.soc_min - SOC_TOLERANCE <= soc_final <= float(self.soc_final[-1]) + SOC_TOLERANCE:
            return None
        return float(np.interp(soc_final, self.soc_final, self.cost_g))


def frontier_ratio(cost_g: float, soc_final: float, frontier: Frontier | None) -> tuple[float | None, str | None]:
    """(``cost_g`` / F(``soc_final``), None), or (None, why not)."""
    if frontier is None:
        return None, f"{REFERENCE} published no frontier"
    ref = frontier.cost_at(float(soc_final))
    if ref is None:
        return None, (f"final SOC {soc_final:.4f} outside the frontier's range "
                      f"[{frontier.soc_min:.4f}, {frontier.soc_final[-1]:.4f}]")
    if ref <= 0.0:
        return None, f"the frontier's cost at final SOC {soc_final:.4f} is {ref:.6g} g, not positive"
    return float(cost_g) / ref, None


def with_reference(strategies: Iterable[str]) -> tuple[list[str], bool]:
    """``strategies`` with :data:`REFERENCE` added (last) if missing; and whether it was added."""
    names = list(dict.fromkeys(strategies))
    return (names, False) if REFERENCE in names else (names + [REFERENCE], True)


def display_name(strategy: str) -> str:
    """The name tables and figures show: with its class's ``label_suffix`` (``dp`` marked thermal-blind)."""
    cls = strategy_class(strategy)
    return str(strategy) + (cls.label_suffix if cls is not None else "")


def reference_text(ref_row: Mapping[str, Any] | None, frontier: Frontier | None) -> str:
    """What the ratios of a cycle and scenario are measured against, for the ``reference`` column."""
    if ref_row is None:
        return f"none ({REFERENCE} did not run)"
    if frontier is not None and frontier.grid:
        return f"{REFERENCE}: {frontier.grid}"
    grid = (ref_row.get("strategy_settings") or {}).get("grid")
    grid_text = " x ".join(f"{k} {v}" for k, v in grid.items()) if isinstance(grid, Mapping) else str(grid or "")
    what = "no frontier published" if frontier is None else "frontier without a grid description"
    return f"{REFERENCE} ({what}{'; grid ' + grid_text if grid_text else ''})"


def add_yardstick_columns(rows: list[dict]) -> None:
    """Fill every run row's ``frontier_ratio`` (None off the frontier's range, with a ``frontier_note``),
    ``fixed_price_ratio``, ``fuel_vs_thermal_blind_dp_pct`` and ``reference`` from the ``dp_thermal`` and ``dp`` rows
    of its cycle and scenario."""
    refs = {(r["cycle"], r["scenario"]): r for r in rows if r["strategy"] == REFERENCE}
    blind = {(r["cycle"], r["scenario"]): r for r in rows if r["strategy"] == BLIND_DP}
    frontiers: dict[tuple[str, str], tuple[Frontier | None, str | None]] = {}
    for key, ref in refs.items():
        try:
            frontiers[key] = (Frontier.from_settings(ref.get("strategy_settings")), None)
        except ValueError as exc:
            frontiers[key] = (None, str(exc))
    for r in rows:
        key = (r["cycle"], r["scenario"])
        ref = refs.get(key)
        frontier, problem = frontiers.get(key, (None, f"{REFERENCE} did not run on this cycle and scenario"))
        r["frontier_ratio"], r["frontier_note"] = ((None, problem) if problem is not None
                                                   else frontier_ratio(r["cost_g"], r["soc_final"], frontier))
        r["fixed_price_ratio"] = _ratio(r, ref)
        pct = _ratio(r, blind.get(key))
        r["fuel_vs_thermal_blind_dp_pct"] = None if pct is None else 100.0 * pct
        r["reference"] = reference_text(ref, frontier)


def _ratio(row: Mapping[str, Any], ref: Mapping[str, Any] | None) -> float | None:
    """Corrected fuel of ``row`` over that of ``ref`` (None without a reference or with a non-positive one)."""
    if ref is None or not ref.get("fuel_corrected_l_per_100km") or ref["fuel_corrected_l_per_100km"] <= 0.0:
        return None
    return float(row["fuel_corrected_l_per_100km"]) / float(ref["fuel_corrected_l_per_100km"])


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


def is_family_row(r: Mapping[str, Any]) -> bool:
    """A seed family's own row (not one of its members'): its ``strategy`` is its ``family``."""
    return r.get("family") is not None and r["strategy"] == r["family"]


def add_score_columns(rows: list[dict]) -> None:
    """Fill the score's columns (``score``, ``score_ci_low``, ``score_ci_high``, ``score_anchor_ratio``,
    ``score_note``) of every row: runs against :data:`ANCHOR`'s run of their cycle and scenario; family rows as the
    aggregate of their members' scores (cycle and scenario ``all``: over every one)."""
    anchors = {(r["cycle"], r["scenario"]): r.get("frontier_ratio") for r in rows
               if r["strategy"] == ANCHOR and r.get("family") is None}
    runs = [r for r in rows if not is_family_row(r)]
    for r in runs:
        key = (r["cycle"], r["scenario"])
        r["score_anchor_ratio"] = anchors.get(key)
        r["score"], r["score_note"] = (normalised_score(r.get("frontier_ratio"), anchors[key]) if key in anchors
                                       else (None, f"{ANCHOR} did not run on this cycle and scenario"))
        r["score_ci_low"] = r["score_ci_high"] = None
    for f in filter(is_family_row, rows):
        members = [m for m in runs if m.get("family") == f["family"]
                   and (f["cycle"] == "all" or (m["cycle"], m["scenario"]) == (f["cycle"], f["scenario"]))]
        agg = aggregate(_by_episode(members))
        f.update({k: agg[k] for k in ("score", "score_ci_low", "score_ci_high")})
        f["score_anchor_ratio"] = None
        f["score_note"] = (f"{agg['excluded']} of {agg['n'] + agg['excluded']} runs left out (ill-conditioned or "
                           "without a ratio)") if agg["excluded"] else None


def _by_episode(rows: Iterable[dict]) -> list[list[tuple[float | None, str | None]]]:
    """The ``(score, note)`` of ``rows`` grouped by cycle and scenario, in order of appearance."""
    groups: dict[tuple[str, str], list[tuple[float | None, str | None]]] = {}
    for r in rows:
        groups.setdefault((r["cycle"], r["scenario"]), []).append((r.get("score"), r.get("score_note")))
    return list(groups.values())


def strategy_aggregates(rows: Sequence[dict]) -> list[dict]:
    """Per strategy (runs, not seed families or their members), the aggregate score over every cycle × scenario it
    ran on, in the rows' order: ``{"strategy", "episodes", **aggregate}``."""
    runs = [r for r in rows if r.get("family") is None]
    out = []
    for name in dict.fromkeys(r["strategy"] for r in runs):
        groups = _by_episode(r for r in runs if r["strategy"] == name)
        out.append({"strategy": name, "episodes": len(groups), **aggregate(groups)})
    return out
