"""The benchmark's yardstick: every run against the thermal optimum (``dp_thermal``) of its cycle and scenario.

The reference run publishes in its settings (``strategy_settings``) the optimum's cost against the final SOC,
``"frontier": {"soc_final": [...], "cost_g": [...], "grid": "<method and grid>"}``, sorted by SOC, the cost
(:func:`hev_thermal_env.metrics.yardstick_cost_g`) non-decreasing in it. :func:`add_yardstick_columns` gives each
row ``frontier_ratio`` (``cost_g`` / F(``soc_final``), F interpolated on the frontier; None outside its range, with
a ``frontier_note``), ``fixed_price_ratio``, ``fuel_vs_thermal_blind_dp_pct`` and ``reference``. ``dp`` plans with
the thermal state held: labelled thermal-blind everywhere (its class's ``label_suffix``). See docs/metrics.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from hev_thermal_env.agents import strategy_class

REFERENCE = "dp_thermal"
"""The strategy whose run is the yardstick (added to every benchmark)."""
BLIND_DP = "dp"
"""The thermal-blind DP, kept as the reference of ``fuel_vs_thermal_blind_dp_pct``."""
SOC_TOLERANCE = 1e-9  # a final SOC this close to the frontier's end is on it (float round-off)


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


def frontier_sample(soc_final, cost_g, max_points: int = 200) -> dict[str, Any]:
    """Every k-th breakpoint of a frontier (and the last), at most about ``max_points``: for records and plots,
    where thousands of breakpoints would only bloat a file. Ratios are taken against the full frontier."""
    soc, cost = np.asarray(soc_final, dtype=float), np.asarray(cost_g, dtype=float)
    every = max(1, int(np.ceil(soc.size / max_points)))
    idx = np.unique(np.r_[np.arange(0, soc.size, every), soc.size - 1]) if soc.size else np.arange(0)
    return {"soc_final": [round(float(x), 6) for x in soc[idx]], "cost_g": [round(float(x), 4) for x in cost[idx]],
            "every_kth_breakpoint": every, "breakpoints": int(soc.size)}


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
    if REFERENCE in names:
        return names, False
    return names + [REFERENCE], True


def display_name(strategy: str) -> str:
    """The name tables and figures show: with its class's ``label_suffix`` (``dp`` and ``dp:LABEL`` marked
    thermal-blind)."""
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
    """Fill ``frontier_ratio``, ``frontier_note``, ``fixed_price_ratio``, ``fuel_vs_thermal_blind_dp_pct`` and
    ``reference`` of every run row, from the ``dp_thermal`` and ``dp`` rows of its cycle and scenario."""
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
