"""The paper: its Table 3 (:mod:`.figures`); the table of all its figures, measuring and judging ours are the
workshop's, ``tools/paper``."""
