"""The paper reproduction: one set of measuring functions (:mod:`.measure`: the calibration's and the tests' too), the
verdicts of ours against the one table of the paper's figures, :mod:`.figures` (:mod:`.verdicts`),
and the report ``evaluate.py paper`` (:mod:`.report`, with its figures, :mod:`.plots`)."""
