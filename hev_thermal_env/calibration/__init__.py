"""Calibration of the motor's thermal model against the paper's figures.

``python -m hev_thermal_env.calibration --out DIR`` fits the thermal network and the eq 10 closures (:mod:`.fit`)
to the figures named in :data:`~hev_thermal_env.paper.figures.CALIBRATION_TARGETS` and writes the parameters and
the residual table (:mod:`.report`). ``paper_bus()``'s thermal defaults hold the values it writes.
"""
