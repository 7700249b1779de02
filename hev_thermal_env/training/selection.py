"""Choosing ``best_model.zip``: a scorer turns one evaluation into a score, and the lowest score wins.

``eval.selection`` names the scorer (:data:`SCORERS`, docs/training.md): the mean corrected fuel relative to a
strategy on the same runs plus :data:`VIOLATION_PENALTY` per run whose ``|ΔSOC|`` exceeds :data:`SOC_BOUND`
(:func:`fuel_ratio_score`), or ``final``, which keeps the latest evaluation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.score import SOC_BOUND

#: Added to the score for every evaluation run beyond :data:`SOC_BOUND` (a fuel ratio is about 1).
VIOLATION_PENALTY = 1000.0
#: The scorer of a run whose hyperparameters name none.
DEFAULT_SCORER = "fuel_vs_ecms"


@dataclasses.dataclass(frozen=True)
class Score:
    """A checkpoint's score (lower is better), whether it qualifies, and the fuel ratio of each run."""

    value: float
    qualified: bool
    ratios: tuple[float, ...]
    violations: int = 0

    def describe(self, short: str) -> str:
        """One line: the mean fuel ratio and, if so, the disqualification."""
        text = f"{short} {np.mean(self.ratios):.4f}"
        return text if self.qualified else f"{text} (disqualified: {self.violations} run(s) over the SOC limit)"


@dataclasses.dataclass(frozen=True)
class Scorer:
    """A selection rule: ``score(results, reference) -> Score`` (``results`` one dict per evaluation run,
    ``reference`` its value per :func:`run_key`), ``reference(cycle, scenario) -> float``; ``label`` the rule in
    words, ``short`` the score's name in log lines, ``reference_name`` what the fuel ratios divide by."""

    name: str
    label: str
    score: Callable[[Sequence[dict[str, Any]], dict[str, float]], Score]
    reference: Callable[[str, str], float]
    short: str = "score"
    reference_name: str = ""
    keep_latest: bool = False


def run_key(cycle: str, scenario: str) -> str:
    """The key of one evaluation run in a reference table: ``"cycle / scenario"``."""
    return f"{cycle} / {scenario}"


def fuel_ratio_score(results: Sequence[dict[str, Any]], reference: dict[str, float]) -> Score:
    """Mean fuel ratio to the reference plus :data:`VIOLATION_PENALTY` per run with |ΔSOC| > :data:`SOC_BOUND`."""
    if not results:
        raise ValueError("no evaluation results to score")
    ratios = []
    for r in results:
        key = run_key(r["cycle"], r["scenario"])
        if key not in reference:
            raise KeyError(f"no reference fuel for {key!r}; known: {sorted(reference)}")
        ratios.append(float(r["fuel_corrected_l_per_100km"]) / float(reference[key]))
    violations = int(sum(abs(float(r["delta_soc"])) > SOC_BOUND for r in results))
    value = float(np.mean(ratios)) + VIOLATION_PENALTY * violations
    return Score(value, violations == 0, tuple(ratios), violations)


def _fuel_scorer(strategy: str) -> Scorer:
    def reference(cycle: str, scenario: str) -> float:  # the corrected fuel [L/100 km] of the strategy
        return float(run_strategy(get_strategy(strategy), cycle, scenario).summary["fuel_corrected_l_per_100km"])

    return Scorer(f"fuel_vs_{strategy}",
                  f"lowest mean corrected fuel ÷ {strategy.upper()} on the validation runs (|ΔSOC| > {SOC_BOUND:g} "
                  f"on any run disqualifies)",
                  fuel_ratio_score, reference, short=f"fuel ÷ {strategy.upper()}", reference_name=strategy.upper())


#: The registered scorers by name.
SCORERS: dict[str, Scorer] = {
    "fuel_vs_ecms": _fuel_scorer("ecms"),
    "fuel_vs_rule": _fuel_scorer("rule"),
    "final": dataclasses.replace(_fuel_scorer("ecms"), name="final", keep_latest=True,
                                 label="the latest evaluation, so the final model (fuel ÷ ECMS reported)"),
}


def get_scorer(name: str) -> Scorer:
    """The registered scorer ``name``."""
    if name not in SCORERS:
        raise ValueError(f"unknown eval.selection {name!r}; registered scorers: {', '.join(SCORERS)}")
    return SCORERS[name]


def compute_references(scorer: Scorer, cycles: Sequence[str], scenarios: Sequence[str],
                       known: dict[str, float] | None = None) -> dict[str, float]:
    """The reference of every cycle × scenario (those in ``known`` are kept, the others computed)."""
    out = dict(known or {})
    for scenario in scenarios:
        for cycle in cycles:
            key = run_key(cycle, scenario)
            if key not in out:
                out[key] = round(float(scorer.reference(cycle, scenario)), 6)
    return out


def is_better(score: float, best: float | None, keep_latest: bool = False) -> bool:
    """Whether a checkpoint scoring ``score`` replaces the best so far (``best`` None: none yet); with
    ``keep_latest`` (the ``final`` selection) every new checkpoint does."""
    return keep_latest or (bool(np.isfinite(score)) and (best is None or score < best))
