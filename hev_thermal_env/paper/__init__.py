"""The paper: one table of its figures and the judging of ours against it (:mod:`.figures`, with the calibration's
targets), one set of measuring functions (:mod:`.measure`) and the reproduction report ``evaluate.py paper``
(:mod:`.report`, with its figures, :mod:`.plots`)."""
