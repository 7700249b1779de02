"""Planning over a known cycle, on the env's own physics and reward: the planners of ``dp`` and ``dp_thermal``.

:mod:`.problem`: what a planner needs from an environment; :mod:`.soc_dp`: backward DP with SOC as the state
(thermal-blind) on the corridor of :mod:`.corridor`; :mod:`.thermal_optimum`: the thermal optimum and its frontier, by
the forward search of :mod:`.search` over the bins of :mod:`.bins` (heat priced by :mod:`.heat_value`);
:mod:`.plan_cache`: solved thermal-optimum plans kept on disk.
"""
