"""Evaluation of strategies: one run (:mod:`.runner`), the benchmark (:mod:`.benchmark`, against the thermal
optimum, :mod:`.yardstick`) and their figures (:mod:`.plots`, :mod:`.fuel_chart`, :mod:`.styles`). The paper report
lives in :mod:`hev_thermal_env.paper`. Nothing here imports torch: the PPO strategy loads it when asked for.
"""

from .runner import RunResult, run_strategy

__all__ = ["RunResult", "run_strategy"]
