"""What a kelvin of motor heat is worth at each stage: the price the thermal optimum's bins put on heat (:mod:`.bins`).

Within a bin the search keeps the cheapest states; two states of one bin can differ by most of a bin's width in
every temperature (2 K of the stator/housing, 8 K of the winding). Where heat costs nothing (a cool motor, far from
its limits) the cheaper one is the better; near the overheat soft limit or the cutoff a kelvin of the housing costs
grams at every later step (the quadratic overheat term, the cutoff's price), and keeping the cheaper-but-hotter state
loses the better lineage (200 s-long drifts of a few kelvin: on Beijing in ``hot`` the 2 K bins left ``rule`` 1.8 %
below the frontier). So the bins compare cost + battery energy at the reward's price + heat at these prices.

:func:`heat_prices` measures them along a reference path (an exact action sequence): from every
:data:`EVERY`-th stage, the path's remaining actions replayed from its state with one temperature raised and lowered
by :data:`DELTA_K` (the other columns as they were); the difference of the rest of the path's cost (the search's cost
plus the battery energy at the reward's price) over 2·ΔT, at least 0 (cooler is never worse in this physics), and
linear between the sampled stages; 0 at the end. A price ranks states within a bin and sets how wide the temperature
bins are (:meth:`~.search.SearchGrid.stage_widths`); every kept path is still an exact action sequence with its exact
cost.
"""

from __future__ import annotations

import numpy as np

from hev_thermal_env.envs.reward import stage_cost_g
from hev_thermal_env.physics import core

from .problem import DPProblem

#: The priced temperatures, in the order of the price columns.
PRICED = (core.TEMP_C, core.WINDING_C, core.COOLANT_C)
#: Stages between two measured prices; the temperature step of the finite difference (K).
EVERY, DELTA_K = 10, 1.0


def heat_prices(problem: DPProblem, u_ref: np.ndarray) -> np.ndarray:
    """Prices [n_stages + 1, len(PRICED)] (g/K) of the temperatures after each stage (module docstring)."""
    n = problem.n_stages
    starts = np.arange(0, n, EVERY)
    rows = starts.size * len(PRICED) * 2
    start = np.repeat(starts, len(PRICED) * 2)
    col = np.tile(np.repeat(np.array(PRICED), 2), starts.size)
    sign = np.tile([1.0, -1.0], starts.size * len(PRICED))
    rp = problem.reward_params
    price = rp.prices.battery_g_per_j(problem.lhv) * rp.soc_energy_weight
    st = np.repeat(problem.state0[None, :], rows, axis=0)
    ref = problem.state0[None, :].copy()
    adj = np.zeros(rows)
    for k in range(n):
        new = start == k
        if np.any(new):
            st[new] = ref[0]
            st[new, col[new]] += sign[new] * DELTA_K
        active = start <= k
        so, out = problem.step(np.vstack([ref, st[active]]), np.full(1 + int(active.sum()), u_ref[k]), k)
        cost = stage_cost_g(rp, out, so, problem.soc_target, problem.lhv, problem.core.dt_s, battery=False,
                            overheat=True)
        adj[active] += cost[1:] + price * out[1:, core.BATT_CHEM] * problem.core.dt_s
        ref, st[active] = so[:1], so[1:]
    diff = (adj[sign > 0] - adj[sign < 0]).reshape(starts.size, len(PRICED)) / (2.0 * DELTA_K)
    mu = np.maximum(diff, 0.0)
    # the price of the temperature after stage i: measured from the start of stage i + 1
    at = np.arange(n + 1)
    out_mu = np.column_stack([np.interp(at, np.r_[starts, n], np.r_[mu[:, d], 0.0]) for d in range(len(PRICED))])
    return out_mu
