"""The reward of ``HevThermal-v0``, written once: the env, the vector env, DP and ECMS all call it.

Every term is in grams of diesel (negative = cost), so the return of an episode reads as
"minus fuel-equivalent grams":

* ``reward_fuel``     = −fuel_weight · fuel_g
* ``reward_miss``     = −miss_weight · (price of the missed wheel energy, :class:`~hev_thermal_env.prices.Prices`)
* ``reward_soc``      = −soc_energy_weight · (fuel equivalent of the battery's chemical energy this step)
                        − soc_deviation_weight · ((SOC − SOC_target) / soc_deviation_scale)²
* ``reward_overheat`` = −overheat_temp_weight · max(T − overheat_soft_limit_c, 0)² − cutoff_weight · [cut off]
                        − derate_weight · PWM

With the default weights the episode's fuel + miss + battery-energy terms equal minus the corrected
fuel of :mod:`hev_thermal_env.metrics` (same prices), so DP and ECMS, which minimise the same
terms, optimise the metric they are judged by. :func:`reward_kernel` is the one compiled
implementation; :meth:`RewardParams.weights` switches terms off for planners that price them
elsewhere (ECMS prices the battery with its own equivalence factor).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..physics import core as C
from ..physics.jit import jit
from ..physics.params import Params, spec
from ..prices import Prices

REWARD_TERMS = ("reward_fuel", "reward_miss", "reward_soc", "reward_overheat")
"""Names of the reward terms, in the column order of :func:`reward_kernel`'s ``terms``."""

# positions in the weight vector of reward_kernel
(W_FUEL, W_MISS, W_SOC_ENERGY, W_SOC_DEV, W_SOC_SCALE, W_TEMP, W_SOFT_LIMIT, W_CUTOFF, W_DERATE, W_BATT_PRICE,
 W_MISS_PRICE, N_WEIGHTS) = range(12)


@dataclasses.dataclass(frozen=True)
class RewardParams(Params):
    """Weights of the reward terms and the prices behind them; every one is a constructor argument of the env."""

    fuel_weight: float = spec(1.0, "per gram of fuel", min=0.0)
    miss_weight: float = spec(1.0, "per gram of the price of missed wheel energy", min=0.0)
    soc_energy_weight: float = spec(1.0, "per fuel-equivalent gram of battery energy used", min=0.0)
    soc_deviation_weight: float = spec(0.2, "per step at one soc_deviation_scale away from the target (quadratic)",
                                       min=0.0)
    soc_deviation_scale: float = spec(0.1, "SOC distance that costs soc_deviation_weight per step", min=0.0,
                                      min_exclusive=True)
    overheat_soft_limit_c: float = spec(60.0, "motor temperature above which overheating is penalised")
    overheat_temp_weight: float = spec(0.05, "per step per K² above the soft limit", min=0.0)
    cutoff_weight: float = spec(20.0, "per step with the motor cut off by its 70 °C protection", min=0.0)
    derate_weight: float = spec(0.0, "per step per unit heat index (PWM)", min=0.0)
    prices: Prices = dataclasses.field(default_factory=Prices)

    def weights(self, lhv_j_per_g: float, *, battery: bool = True, soc_deviation: bool = True,
                overheat: bool = True) -> np.ndarray:
        """The weight vector of :func:`reward_kernel`; terms switched off get weight 0."""
        w = np.zeros(N_WEIGHTS)
        w[W_FUEL] = self.fuel_weight
        w[W_MISS] = self.miss_weight
        w[W_SOC_ENERGY] = self.soc_energy_weight if battery else 0.0
        w[W_SOC_DEV] = self.soc_deviation_weight if soc_deviation else 0.0
        w[W_SOC_SCALE] = self.soc_deviation_scale
        w[W_TEMP] = self.overheat_temp_weight if overheat else 0.0
        w[W_SOFT_LIMIT] = self.overheat_soft_limit_c
        w[W_CUTOFF] = self.cutoff_weight if overheat else 0.0
        w[W_DERATE] = self.derate_weight if overheat else 0.0
        w[W_BATT_PRICE] = self.prices.battery_g_per_j(lhv_j_per_g)
        w[W_MISS_PRICE] = self.prices.miss_g_per_j(lhv_j_per_g)
        return w


@jit
def reward_row(w, out, st, b, soc_target, dt_s):
    """The four terms of row ``b`` (fuel, miss, soc, overheat) and their sum, in a fixed order."""
    fuel = -w[W_FUEL] * out[b, C.FUEL_G]
    miss = -w[W_MISS] * (out[b, C.MISSED_J] * w[W_MISS_PRICE])
    e = (st[b, C.SOC] - soc_target) / w[W_SOC_SCALE]
    soc = -w[W_SOC_ENERGY] * (out[b, C.BATT_CHEM] * dt_s * w[W_BATT_PRICE]) - w[W_SOC_DEV] * (e * e)
    over = max(st[b, C.TEMP_C] - w[W_SOFT_LIMIT], 0.0)
    pwm = min(max(st[b, C.HEAT_X], 0.0), 1.0)
    heat = -w[W_TEMP] * over * over - w[W_CUTOFF] * st[b, C.CUTOFF] - w[W_DERATE] * pwm
    return fuel, miss, soc, heat, ((fuel + miss) + soc) + heat


@jit
def reward_kernel(w, out, state_after, soc_target, dt_s, terms, total):
    """Reward of a batch of steps: ``terms`` [B, 4] (``REWARD_TERMS`` order) and ``total`` [B].

    ``out`` [B, N_OUT] and ``state_after`` [B, N_STATE] come from the physics core; ``soc_target`` [B].
    """
    for b in range(out.shape[0]):
        fuel, miss, soc, heat, tot = reward_row(w, out, state_after, b, soc_target[b], dt_s)
        terms[b, 0] = fuel
        terms[b, 1] = miss
        terms[b, 2] = soc
        terms[b, 3] = heat
        total[b] = tot


def reward_terms(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: np.ndarray | float,
                 lhv_j_per_g: float, dt_s: float = 1.0, **switches: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`reward_kernel` on a batch: (terms [B, 4], total [B]); ``switches`` as :meth:`RewardParams.weights`."""
    b = out.shape[0]
    terms = np.empty((b, len(REWARD_TERMS)))
    total = np.empty(b)
    target = np.broadcast_to(np.asarray(soc_target, dtype=np.float64), (b,))
    reward_kernel(params.weights(lhv_j_per_g, **switches), np.ascontiguousarray(out, dtype=np.float64),
                  np.ascontiguousarray(state_after, dtype=np.float64), np.ascontiguousarray(target), float(dt_s),
                  terms, total)
    return terms, total


def stage_cost_g(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: np.ndarray | float,
                 lhv_j_per_g: float, dt_s: float, *, battery: bool = True, soc_deviation: bool = False,
                 overheat: bool = False) -> np.ndarray:
    """Cost (fuel-equivalent grams, = −reward) of each row of a batch step, with some terms switched off.

    What DP and ECMS minimise: always fuel and missed wheel energy; with ``battery`` the battery
    energy, with ``soc_deviation`` the quadratic SOC term, with ``overheat`` the overheating terms.
    """
    _, total = reward_terms(params, out, state_after, soc_target, lhv_j_per_g, dt_s, battery=battery,
                            soc_deviation=soc_deviation, overheat=overheat)
    return -total
