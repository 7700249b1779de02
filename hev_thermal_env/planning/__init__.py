"""Planning over a known cycle, on the env's own physics and reward: the planners of ``dp`` and ``dp_thermal``.

:mod:`.problem`: what a planner needs from an environment; :mod:`.soc_dp`: backward DP with SOC as the state
(thermal-blind) on its corridor; :mod:`.thermal_optimum`: the thermal optimum and its frontier (plans kept on disk), by
the forward search of :mod:`.search` over the stages of :mod:`.stage`.
"""
