"""Evaluation of strategies: one run, the benchmark and their figures.

* :mod:`.runner`: :func:`run_strategy` drives one cycle with one strategy (:class:`RunResult`);
* :mod:`.benchmark`: every strategy on every cycle and scenario (``run_benchmark``), measured against
  the thermal optimum (:mod:`.yardstick`), with seed families (:mod:`.families`) and the result
  files (:mod:`.results_table`);
* :mod:`.plots`: :func:`plot_run` (the trace figure) and the benchmark figures; :mod:`.fuel_chart`:
  ``fuel_vs_optimum.png``; :mod:`.styles`: strategy order, colours and legends shared by every figure.

The paper reproduction report lives in :mod:`hev_thermal_env.paper`.

Nothing here imports torch: the PPO strategy loads it when it is asked for.
"""

from .runner import RunResult, run_strategy

__all__ = ["RunResult", "run_strategy"]
