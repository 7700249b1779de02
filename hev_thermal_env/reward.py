"""The reward of ``HevThermal-v0`` and the price DP and ECMS put on the same outcomes.

Every term is in grams of diesel (negative = cost), so the return of an episode reads as
"minus fuel-equivalent grams":

* ``reward_fuel``     = −fuel_weight · fuel_g
* ``reward_miss``     = −miss_weight · (the corrected-fuel metric's price of the missed wheel energy:
                        the fuel to deliver it from the battery and put that back with the engine,
                        1.23 times what the engine would burn to deliver it directly)
* ``reward_soc``      = −soc_energy_weight · (fuel equivalent of the battery's chemical energy this step)
                        − soc_deviation_weight · ((SOC − SOC_target) / 0.1)²
* ``reward_overheat`` = −temp_weight · max(T − soft_limit, 0)² − cutoff_weight · [motor cut off]
                        − derate_weight · PWM

The fuel equivalents use the same stated efficiencies as the corrected-fuel metric
(:func:`hev_thermal_env.physics.simulate.corrections_g`), so with the default weights of 1 the
episode's fuel + battery + miss terms equal the corrected fuel: not driving costs more than driving
would, in the reward and in the metric alike.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .physics import core as C
from .physics.params import Params, spec
from .physics.simulate import battery_price_g_per_j, miss_price_g_per_j


@dataclasses.dataclass(frozen=True)
class RewardParams(Params):
    """Weights of the reward terms; every one is a constructor argument of the env."""

    fuel_weight: float = spec(1.0, "per gram of fuel", min=0.0)
    miss_weight: float = spec(1.0, "per gram of the metric's price of missed wheel energy", min=0.0)
    soc_energy_weight: float = spec(1.0, "per fuel-equivalent gram of battery energy used", min=0.0)
    soc_deviation_weight: float = spec(0.2, "per step at 0.1 SOC away from the target (quadratic)", min=0.0)
    overheat_soft_limit_c: float = spec(60.0, "motor temperature above which overheating is penalised")
    overheat_temp_weight: float = spec(0.05, "per step per K² above the soft limit", min=0.0)
    cutoff_weight: float = spec(20.0, "per step with the motor cut off by its 70 °C protection", min=0.0)
    derate_weight: float = spec(0.0, "per step per unit heat index (PWM)", min=0.0)


def reward_terms(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: np.ndarray | float,
                 lhv_j_per_g: float, dt_s: float = 1.0) -> dict[str, np.ndarray]:
    """The four reward terms for a batch of steps (``out`` [B, N_OUT], ``state_after`` [B, N_STATE])."""
    batt_g = out[:, C.BATT_CHEM] * dt_s * battery_price_g_per_j(lhv_j_per_g)
    miss_g = out[:, C.MISSED_J] * miss_price_g_per_j(lhv_j_per_g)
    soc = state_after[:, C.SOC]
    temp = state_after[:, C.TEMP_C]
    over = np.maximum(temp - params.overheat_soft_limit_c, 0.0)
    pwm = np.clip(state_after[:, C.HEAT_X], 0.0, 1.0)
    return {
        "reward_fuel": -params.fuel_weight * out[:, C.FUEL_G],
        "reward_miss": -params.miss_weight * miss_g,
        "reward_soc": -params.soc_energy_weight * batt_g
        - params.soc_deviation_weight * ((soc - soc_target) / 0.1) ** 2,
        "reward_overheat": -params.overheat_temp_weight * over * over
        - params.cutoff_weight * state_after[:, C.CUTOFF] - params.derate_weight * pwm,
    }
