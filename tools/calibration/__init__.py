"""Calibration of the motor's thermal model by the pre-registered protocol (docs/calibration/protocol.md):
``python -m tools.calibration`` fits the three parameters the protocol frees (:mod:`.fit`, bounds and
starts read from its YAML by :mod:`.protocol`) to the fitted targets F1-F7 of
:data:`~tools.paper.figures.FITTED`, appends every attempt to the fit log (:mod:`.log`) and writes the
parameters, the residual table (:mod:`.report`) and the generated tables of docs/thermal_model.md (:mod:`.docs`)."""
