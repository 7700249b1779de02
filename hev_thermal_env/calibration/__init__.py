"""Calibration of the motor's thermal model: ``python -m hev_thermal_env.calibration --out DIR`` fits the thermal
network and the eq 10 closures (:mod:`.fit`) to :data:`~hev_thermal_env.paper.figures.CALIBRATION_TARGETS` and writes
the parameters and the residual table (:mod:`.report`), the values ``paper_bus()``'s thermal defaults hold."""
