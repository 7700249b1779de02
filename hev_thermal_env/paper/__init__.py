"""The paper: one table of its figures, targets and checks, with their tolerances (:mod:`.figures`); measuring and
judging ours is the workshop's, ``tools/paper``."""
