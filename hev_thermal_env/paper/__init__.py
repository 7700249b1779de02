"""The paper: one table of its figures (:mod:`.figures`, with the calibration's targets), one set of measuring
functions (:mod:`.measure`) and the reproduction report ``evaluate.py paper`` (:mod:`.report`, with its opening
tables, :mod:`.verdicts`, and figures, :mod:`.plots`)."""
