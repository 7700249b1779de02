"""Evaluation of strategies: one run (:mod:`.runner`), the benchmark (:mod:`.benchmark`, against the thermal
optimum, :mod:`.score`), its figures (:mod:`.plots`, :mod:`.styles`), the tasks' references, results and leaderboard
(:mod:`.references`, :mod:`.submission`, :mod:`.leaderboard`) and offline datasets (:mod:`.datasets`). Nothing here
imports torch: the PPO strategy loads it when asked for.
"""

from .runner import RunResult, run_strategy

__all__ = ["RunResult", "run_strategy"]
