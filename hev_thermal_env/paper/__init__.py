"""The paper: one table of its figures, the calibration protocol's targets and checks, and the judging of ours
against them (:mod:`.figures`). What measures ours and the reproduction report are the workshop's, ``tools/paper``."""
