"""The maintainers' workshop: what checks, fits and documents the package, run from a source checkout and never
installed (``pyproject.toml`` installs ``hev_thermal_env`` alone). It imports the package; the package never imports
it, but for ``evaluate.py paper``, which loads :mod:`tools.paper` when it runs.

* :mod:`tools.paper`: the runs behind the paper's figures, what is measured on them, and the reproduction report;
* :mod:`tools.calibration`: the thermal model's fit to the paper's figures (``python -m tools.calibration``);
* :mod:`tools.sweep`: the hyperparameter sweep on Ray Tune that tuned the shipped files (``python -m tools.sweep``);
* :mod:`tools.audit`: the energy audit of a run, each component against its own map (a test oracle);
* :mod:`tools.family_bounds`: the documented envelope of the cycle families' statistics (a test oracle);
* :mod:`tools.fuzz`: random-action fuzzing of the environment against its invariants (``benchmarks/fuzz.py``);
* :mod:`tools.parameters_page`: ``docs/parameters.md`` (``python -m tools.parameters_page > docs/parameters.md``).

Their tests are in ``tests/`` (``test_paper_table.py``, ``test_calibration.py``, ``test_audit.py``, ``test_fuzz.py``,
...).
"""
