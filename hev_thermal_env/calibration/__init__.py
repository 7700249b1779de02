"""Calibration of the motor's thermal model against the paper's figures (issue 11).

``python -m hev_thermal_env.calibration --out DIR`` fits the thermal network and the eq 10
closures (:mod:`.fit`) to the targets (:mod:`.targets`) and writes ``DIR/fitted_params.yaml``,
``DIR/residuals.md`` and ``DIR/residuals.json``. ``paper_bus()``'s thermal defaults hold the
values it writes; ``--check`` fails if they differ.
"""

from .fit import FitResult, fitted_fields, run_fit
from .targets import TARGETS, Target, measure

__all__ = ["FitResult", "TARGETS", "Target", "fitted_fields", "measure", "run_fit"]
