"""Calibration of the motor's thermal model against the paper's figures.

``python -m hev_thermal_env.calibration --out DIR`` fits the thermal network and the eq 10
closures (:mod:`.fit`) to the paper's figures named in
:data:`~hev_thermal_env.paper.figures.CALIBRATION_TARGETS` (measured by
:mod:`hev_thermal_env.paper.measure`) and writes ``DIR/fitted_params.yaml``, ``DIR/residuals.md``
and ``DIR/residuals.json`` (:mod:`.report`). ``paper_bus()``'s thermal defaults hold the values it
writes; ``--check`` fails if they differ.
"""

from .fit import TARGETS, FitResult, fitted_fields, run_fit

__all__ = ["FitResult", "TARGETS", "fitted_fields", "run_fit"]
