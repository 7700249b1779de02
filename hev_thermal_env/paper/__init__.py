"""The paper: one table of its figures, the calibration protocol's targets and checks, and the judging of ours
against them (:mod:`.figures`), one set of measuring functions (:mod:`.measure`) and the reproduction report
``evaluate.py paper`` (:mod:`.report`, with its figures, :mod:`.plots`)."""
