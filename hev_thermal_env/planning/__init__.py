"""Planning over a known cycle: the SOC dynamic programme and the thermal optimum, on the env's own physics and reward.

The planners behind the ``dp`` and ``dp_thermal`` strategies (:mod:`hev_thermal_env.agents`), each
module named for what it holds:

* :mod:`.problem`: what a planner needs from an environment (:class:`~.problem.DPProblem`);
* :mod:`.soc_dp`: backward DP with SOC as the state (thermal-blind), on the SOC corridor of
  :mod:`.corridor`;
* :mod:`.thermal_optimum`: the thermal optimum and its frontier, by the forward search over exact
  states of :mod:`.search`, whose bins are :mod:`.bins`;
* :mod:`.plan_cache`: solved thermal-optimum plans kept on disk.
"""
