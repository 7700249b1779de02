"""Evaluation of strategies: one run, the benchmark, the paper report and their figures.

* :mod:`.runner`: :func:`run_strategy` drives one cycle with one strategy (:class:`RunResult`);
* :mod:`.benchmark`: every strategy on every cycle and scenario, the result table (``run_benchmark``);
* :mod:`.plots`: :func:`plot_run` and the benchmark figures;
* :mod:`.paper`: the paper reproduction report (``build_report``).

Nothing here imports torch: the PPO strategy loads it when it is asked for.
"""

from .runner import RunResult, make_env, run_strategy

__all__ = ["RunResult", "make_env", "run_strategy"]
