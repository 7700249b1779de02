"""Evaluation of strategies: one run, the benchmark, the paper report and their figures.

* :mod:`.runner`: :func:`run_strategy` drives one cycle with one strategy (:class:`RunResult`);
* :mod:`.benchmark`: every strategy on every cycle and scenario (``run_benchmark``), measured against
  the thermal optimum (:mod:`.yardstick`), with seed families (:mod:`.families`) and the result
  files (:mod:`.results_table`);
* :mod:`.plots`: :func:`plot_run` (the trace figure) and the benchmark figures; :mod:`.fuel_chart`:
  ``fuel_vs_optimum.png``; :mod:`.styles`: strategy order, colours and legends shared by every figure;
* :mod:`.paper`: the paper reproduction report (``build_report``), with :mod:`.paper_targets` (the
  paper's figures and tolerances), :mod:`.paper_measure` (the runs), :mod:`.paper_table` (verdicts)
  and :mod:`.paper_figures`.

Nothing here imports torch: the PPO strategy loads it when it is asked for.
"""

from .runner import RunResult, make_env, run_strategy

__all__ = ["RunResult", "make_env", "run_strategy"]
