"""Choosing ``best_model.zip``: a scorer turns one evaluation into a score, and the lowest score wins.

An evaluation is one result per validation cycle × scenario
(:class:`~hev_thermal_env.training.evaluator.PolicyEvaluator`). The run's config names its scorer in
``eval.selection``, one of :data:`SCORERS`:

``fuel_vs_ecms`` (the default) and ``fuel_vs_rule``: the mean over the evaluation runs of the corrected
fuel (``fuel_corrected_l_per_100km``) divided by that of the ``ecms`` / ``rule`` strategy on the same
cycle and scenario (the *reference*, computed once per run). A run whose ``|ΔSOC|`` exceeds
:data:`SOC_LIMIT` disqualifies the checkpoint: each such run adds :data:`VIOLATION_PENALTY` to the
score, so a checkpoint that holds the SOC on every cycle always beats one that does not, and fewer
violations beat more.

Scores are "lower is better"; :func:`is_better` is the one comparison the loop makes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hev_thermal_env.agents import get_strategy
from hev_thermal_env.evaluation.runner import run_strategy

#: Largest |ΔSOC| over a validation cycle a selectable checkpoint may have.
SOC_LIMIT = 0.02
#: Added to the score for every evaluation run beyond :data:`SOC_LIMIT` (a fuel ratio is about 1).
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
    """A selection rule.

    ``score(results, reference) -> Score``: ``results`` one dict per evaluation run (keys ``cycle``,
    ``scenario``, ``return_g``, ``fuel_corrected_l_per_100km``, ``delta_soc``...), ``reference`` the
    reference value of each run by :func:`run_key`. ``reference(cycle, scenario) -> float``: the reference
    value of one run. ``label``: the rule in words, for logs and plots;
    ``short``: the score's name in log lines; ``reference_name``: what the fuel ratios divide by (plots).
    """

    name: str
    label: str
    score: Callable[[Sequence[dict[str, Any]], dict[str, float]], Score]
    reference: Callable[[str, str], float]
    short: str = "score"
    reference_name: str = ""


def run_key(cycle: str, scenario: str) -> str:
    """The key of one evaluation run in a reference table: ``"cycle / scenario"``."""
    return f"{cycle} / {scenario}"


def strategy_reference(strategy: str, **options: Any) -> Callable[[str, str], float]:
    """A reference: the corrected fuel [L/100 km] of ``strategy`` on the cycle and scenario (``run_strategy``)."""

    def reference(cycle: str, scenario: str) -> float:
        res = run_strategy(get_strategy(strategy, **options), cycle, scenario)
        return float(res.summary["fuel_corrected_l_per_100km"])

    return reference


def fuel_ratio_score(results: Sequence[dict[str, Any]], reference: dict[str, float],
                     soc_limit: float = SOC_LIMIT) -> Score:
    """Mean fuel ratio to the reference plus :data:`VIOLATION_PENALTY` per run with |ΔSOC| > ``soc_limit``."""
    if not results:
        raise ValueError("no evaluation results to score")
    ratios = []
    for r in results:
        key = run_key(r["cycle"], r["scenario"])
        if key not in reference:
            raise KeyError(f"no reference fuel for {key!r}; known: {sorted(reference)}")
        ratios.append(float(r["fuel_corrected_l_per_100km"]) / float(reference[key]))
    violations = int(sum(abs(float(r["delta_soc"])) > soc_limit for r in results))
    value = float(np.mean(ratios)) + VIOLATION_PENALTY * violations
    return Score(value, violations == 0, tuple(ratios), violations)


def _fuel_scorer(strategy: str) -> Scorer:
    return Scorer(f"fuel_vs_{strategy}",
                  f"lowest mean corrected fuel ÷ {strategy.upper()} on the validation runs (|ΔSOC| > {SOC_LIMIT:g} "
                  f"on any run disqualifies)",
                  fuel_ratio_score, strategy_reference(strategy), short=f"fuel ÷ {strategy.upper()}",
                  reference_name=strategy.upper())


#: The registered scorers by name.
SCORERS: dict[str, Scorer] = {
    "fuel_vs_ecms": _fuel_scorer("ecms"),
    "fuel_vs_rule": _fuel_scorer("rule"),
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


def is_better(score: float, best: float | None) -> bool:
    """Whether a checkpoint scoring ``score`` replaces the best so far (``best`` None: none yet)."""
    return bool(np.isfinite(score)) and (best is None or score < best)


def best_row_score(rows: Sequence[dict[str, Any]]) -> float | None:
    """The lowest score among evaluation rows (None when there is none)."""
    scores = [float(r["score"]) for r in rows if np.isfinite(float(r["score"]))]
    return min(scores) if scores else None
