"""The paper: one table of its figures, one set of measuring functions, the reproduction report.

* :mod:`.figures`: the paper's figures and their tolerances (:data:`~.figures.PAPER_FIGURES`), and
  which of them the calibration (:mod:`hev_thermal_env.calibration`) fits;
* :mod:`.measure`: the runs behind the figures and what is measured on them (over :mod:`.drive`, a
  light driver of the paper's strategy over the physics core);
* :mod:`.report`: ``evaluate.py paper`` (``build_report``), with :mod:`.verdicts` (the opening
  tables) and :mod:`.plots` (the figures, with the paper's points and bands).
"""

from .figures import PAPER_FIGURE_BY_NAME, PAPER_FIGURES, PaperFigure
from .report import build_report

__all__ = ["PAPER_FIGURES", "PAPER_FIGURE_BY_NAME", "PaperFigure", "build_report"]
