"""The paper: one table of its figures, the calibration protocol's targets and checks, with their tolerances
(:mod:`.figures`). What measures ours and judges it against them, and the reproduction report, are the workshop's,
``tools/paper``."""
