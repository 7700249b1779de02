"""The reward of ``HevThermal-v2`` (v1: other weights), written once: the env, the vector env, DP and ECMS all call it.

Specified in :class:`~hev_thermal_env.envs.HevThermalEnv`, section Rewards, at the prices of
:class:`~hev_thermal_env.prices.Prices`; planners call it on batches through :func:`reward_terms`,
:func:`stage_cost_g` and :func:`soc_band_charge_g`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..physics import core
from ..physics.config import check_physics
from ..physics.jit import jit
from ..physics.params import Params, spec
from ..prices import Prices

REWARD_TERMS = ("reward_fuel", "reward_miss", "reward_soc", "reward_overheat")
"""Names of the reward terms, in the column order of :func:`reward_kernel`'s ``terms``."""

# positions in the weight vector of reward_kernel
(W_FUEL, W_MISS, W_SOC_ENERGY, W_SOC_BAND, W_SOC_BAND_WEIGHT, W_SOC_DEV, W_SOC_SCALE, W_TEMP, W_SOFT_LIMIT,
 W_CUTOFF, W_DERATE, W_BATT_PRICE, W_MISS_PRICE, W_DESCENT, W_DERATE_FROM, W_LIFE, W_CLASS_C, N_WEIGHTS) = range(18)

#: ln 2 / 10 K: the insulation's life halves every 10 K (Montsinger).
LN2_PER_10K = math.log(2.0) / 10.0
MOTOR_LIFE_COST_G = 8000.0 / 1.60 * 835.0
"""Physics v2's price of the insulation's life: the motor and its inverter replaced (8,000 €, a stated assumption for a
90 kW bus drive) at 1.60 € per litre of diesel of 835 g: 4.2 t of diesel, 0.058 g per second at the class
temperature, halving every 10 K below it (docs/environment.md, *Physics versions and the overheat price*)."""


@dataclasses.dataclass(frozen=True)
class RewardParams(Params):
    """Weights of the reward terms and the prices behind them; every one is a constructor argument of the env."""

    fuel_weight: float = spec(1.0, "per gram of fuel", min=0.0)
    miss_weight: float = spec(1.0, "per gram of the price of missed wheel energy", min=0.0)
    soc_energy_weight: float = spec(1.0, "per fuel-equivalent gram of battery energy used", min=0.0)
    soc_band: float = spec(0.01, "half-width of the SOC band around the target inside which the SOC is free "
                                 "(the settlement is zero there)", min=0.0, max=1.0)
    soc_band_weight: float = spec(10000.0, "fuel-equivalent grams per unit SOC outside the band, settled as the SOC "
                                           "moves (potential difference; the episode pays it for its final SOC)",
                                  min=0.0)
    soc_deviation_weight: float = spec(0.0, "per step at one soc_deviation_scale away from the target (quadratic; "
                                            "off by default)", min=0.0)
    soc_deviation_scale: float = spec(0.1, "SOC distance that costs soc_deviation_weight per step", min=0.0,
                                      min_exclusive=True)
    descent_recovery: float = spec(0.6, "share of the potential energy of the route still to descend that the band "
                                        "expects back in the battery (lowers the band's center on high ground; "
                                        "0: a fixed band)", min=0.0, max=1.0)
    overheat_soft_limit_c: float = spec(60.0, "motor temperature above which overheat_temp_weight applies")
    overheat_temp_weight: float = spec(0.0, "per step per K² above the soft limit (physics v1: 0.05)", min=0.0)
    cutoff_weight: float = spec(0.0, "per step with the motor cut off by either protection, beyond the fuel and "
                                     "missed energy the lost assist costs (physics v1: 20)", min=0.0)
    derate_weight: float = spec(0.0, "per step per unit of the heat-index integrator x above derate_from_x (by "
                                     "default the heat index PWM itself: the safety cost's price)", min=0.0)
    derate_from_x: float = spec(0.0, "heat-index integrator x (eq 9) from which derate_weight applies: 0 prices the "
                                     "heat index PWM = clip(x, 0, 1); below 0 also the approach to derating, as "
                                     "ecms_thermal's x_thr (its overload reserve is 0.3 at most)", min=-0.3, max=0.0)
    motor_life_cost_g: float = spec(MOTOR_LIFE_COST_G, "what the motor's insulation life is worth, in grams of diesel: "
                                                       "the motor and inverter replaced at the end of it (physics v1: "
                                                       "0, not priced)", min=0.0)
    insulation_class_temp_c: float = spec(180.0, "the winding insulation's thermal class: class H, 180 °C (IEC 60085), "
                                                 "the hot-spot temperature it lasts insulation_life_h at", min=100.0,
                                          max=250.0)
    insulation_life_h: float = spec(20000.0, "the insulation's life at its class temperature (IEC 60085 / 60216: the "
                                             "thermal class is the temperature of a 20,000 h life)", min=1000.0)
    prices: Prices = dataclasses.field(default_factory=Prices)

    @classmethod
    def for_physics(cls, physics: int = 2) -> RewardParams:
        """The defaults of a physics version: v2 (the fields' defaults) prices overheating by the insulation's life
        (Montsinger: L = 20,000 h · 2^((T_class − T_w)/10 K), :data:`MOTOR_LIFE_COST_G`), v1 by weights (0.05 g/K²
        above 60 °C, 20 g per second cut off)."""
        if check_physics(physics) == 1:
            return cls(overheat_temp_weight=0.05, cutoff_weight=20.0, motor_life_cost_g=0.0)
        return cls()

    @classmethod
    def of(cls, reward: RewardParams | dict | None, physics: int = 2) -> RewardParams:
        """The env's ``reward`` argument as :class:`RewardParams`: None the physics version's defaults, a dict its
        fields over them."""
        if reward is None:
            return cls.for_physics(physics)
        if isinstance(reward, RewardParams):
            return reward
        if isinstance(reward, dict):
            return cls.from_dict({**cls.for_physics(physics).to_dict(), **reward}, where="reward")
        raise TypeError(f"reward: expected RewardParams, a dict or None, got {type(reward).__name__}")

    def weights(self, lhv_j_per_g: float, *, battery: bool = True, soc_deviation: bool = True,
                overheat: bool = True, soc_band: bool = True) -> np.ndarray:
        """The weight vector of :func:`reward_kernel`; terms switched off (planners that price them
        elsewhere, e.g. ECMS the battery) get weight 0. ``soc_deviation`` switches the SOC terms besides the battery
        energy: the band settlement (unless ``soc_band`` is False) and the quadratic deviation."""
        w = np.zeros(N_WEIGHTS)
        w[W_FUEL] = self.fuel_weight
        w[W_MISS] = self.miss_weight
        w[W_SOC_ENERGY] = self.soc_energy_weight if battery else 0.0
        w[W_SOC_BAND] = self.soc_band
        w[W_SOC_BAND_WEIGHT] = self.soc_band_weight if soc_deviation and soc_band else 0.0
        w[W_SOC_DEV] = self.soc_deviation_weight if soc_deviation else 0.0
        w[W_SOC_SCALE] = self.soc_deviation_scale
        w[W_TEMP] = self.overheat_temp_weight if overheat else 0.0
        w[W_SOFT_LIMIT] = self.overheat_soft_limit_c
        w[W_CUTOFF] = self.cutoff_weight if overheat else 0.0
        w[W_DERATE] = self.derate_weight if overheat else 0.0
        w[W_BATT_PRICE] = self.prices.battery_g_per_j(lhv_j_per_g)
        w[W_MISS_PRICE] = self.prices.miss_g_per_j(lhv_j_per_g)
        w[W_DESCENT] = self.descent_recovery
        w[W_DERATE_FROM] = self.derate_from_x
        w[W_LIFE] = self.motor_life_cost_g / (self.insulation_life_h * 3600.0) if overheat else 0.0
        w[W_CLASS_C] = self.insulation_class_temp_c
        return w


#: The reward's arguments the observation carries (``descent_recovery`` places the band's center, the ``soc_target``
#: entry): a trained policy is driven with the values it learned them at.
OBSERVED_REWARD_FIELDS = ("descent_recovery",)


def observation_options(reward: dict | None) -> dict:
    """The env arguments among ``reward`` (an env's ``reward`` mapping, e.g. a run config's ``env.reward``) that shape
    the observation: ``{"reward": {...}}`` with the fields of :data:`OBSERVED_REWARD_FIELDS` it sets, else ``{}``."""
    observed = {k: float(v) for k, v in (reward or {}).items() if k in OBSERVED_REWARD_FIELDS}
    return {"reward": observed} if observed else {}


@jit
def soc_band_potential(w, soc, soc_target):
    """Φ(SOC) of the band settlement: −soc_band_weight · max(|SOC − SOC_target| − soc_band, 0)."""
    return -w[W_SOC_BAND_WEIGHT] * max(abs(soc - soc_target) - w[W_SOC_BAND], 0.0)


def descent_soc(climb_m: np.ndarray, mass_kg: float, gravity_mps2: float, battery_j_per_soc: float) -> np.ndarray:
    """The SOC the descent from each instant to the route's end would return if all of it came back: ``climb_m``
    [n + 1], the height reached at each instant (m, :attr:`~hev_thermal_env.envs.episodes.CycleTables.climb_m`), gives
    ``m · g · (climb_m[k] − climb_m[n]) / battery_j_per_soc``, 0 at the end and on a flat route."""
    h = np.asarray(climb_m, dtype=np.float64)
    return mass_kg * gravity_mps2 * (h - h[-1]) / battery_j_per_soc


@jit
def band_center(w, soc_target, descent):
    """The band's center: ``soc_target − descent_recovery · descent`` (``descent`` from :func:`descent_soc`)."""
    return soc_target - w[W_DESCENT] * descent


@jit
def soc_band_charge_kernel(w, soc, soc_target, charge):
    """−Φ of every SOC in ``soc`` into ``charge``: what the settlement charges an episode ending there."""
    for i in range(soc.shape[0]):
        charge[i] = -soc_band_potential(w, soc[i], soc_target)


def soc_band_charge_g(params: RewardParams, soc: np.ndarray, soc_target: float) -> np.ndarray:
    """What the band settlement of an episode from inside the band to a final ``soc`` adds up to (g, ≥ 0):
    a potential difference, so a planner can charge it once, on the final SOC (DP does)."""
    soc = np.ascontiguousarray(soc, dtype=np.float64).reshape(-1)
    charge = np.empty(soc.size)
    soc_band_charge_kernel(params.weights(1.0), soc, float(soc_target), charge)  # the prices play no part
    return charge


@jit
def reward_row(w, out, st0, st, b, target_before, target_after, dt_s):
    """The four terms of row ``b`` (fuel, miss, soc, overheat) and their sum, in a fixed order; ``st0`` / ``st``: the
    states before / after the step, ``target_before`` / ``target_after``: the band's center at those instants."""
    fuel = -w[W_FUEL] * out[b, core.FUEL_G]
    miss = -w[W_MISS] * (out[b, core.MISSED_J] * w[W_MISS_PRICE])
    e = (st[b, core.SOC] - target_after) / w[W_SOC_SCALE]
    band = (soc_band_potential(w, st[b, core.SOC], target_after)
            - soc_band_potential(w, st0[b, core.SOC], target_before))
    soc = -w[W_SOC_ENERGY] * (out[b, core.BATT_CHEM] * dt_s * w[W_BATT_PRICE]) + band - w[W_SOC_DEV] * (e * e)
    over = max(st[b, core.TEMP_C] - w[W_SOFT_LIMIT], 0.0)
    derate = min(max(st[b, core.HEAT_X] - w[W_DERATE_FROM], 0.0), 1.0 - w[W_DERATE_FROM])  # PWM when it is 0
    off = max(st[b, core.CUTOFF], st[b, core.WINDING_TRIP])  # either protection stops the motor
    heat = -w[W_TEMP] * over * over - w[W_CUTOFF] * off - w[W_DERATE] * derate
    if w[W_LIFE] > 0.0:  # the insulation's life consumed: dt / L(T_w), L halving every 10 K (physics v2)
        heat -= w[W_LIFE] * dt_s * math.exp(LN2_PER_10K * (st[b, core.WINDING_C] - w[W_CLASS_C]))
    return fuel, miss, soc, heat, ((fuel + miss) + soc) + heat


@jit
def reward_kernel(w, out, state_before, state_after, target_before, target_after, dt_s, terms, total):
    """Reward of a batch of steps: ``terms`` [B, 4] (``REWARD_TERMS`` order) and ``total`` [B].

    ``out`` [B, N_OUT] and ``state_after`` [B, N_STATE] come from the physics core, ``state_before`` [B, N_STATE] is
    what it stepped from (the band settlement's start); ``target_before`` and ``target_after`` [B]: the band's center
    before and after the step (:func:`band_center`).
    """
    for b in range(out.shape[0]):
        fuel, miss, soc, heat, tot = reward_row(w, out, state_before, state_after, b, target_before[b],
                                                target_after[b], dt_s)
        terms[b, 0] = fuel
        terms[b, 1] = miss
        terms[b, 2] = soc
        terms[b, 3] = heat
        total[b] = tot


def reward_terms(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: np.ndarray | float,
                 lhv_j_per_g: float, dt_s: float = 1.0, *, state_before: np.ndarray | None = None,
                 **switches: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`reward_kernel` on a batch: (terms [B, 4], total [B]); ``switches`` as :meth:`RewardParams.weights`.

    ``state_before``: the states the batch stepped from ([B, N_STATE], or one [N_STATE] for all rows); without it the
    settlement omits Φ(SOC before), a constant shift among actions from one common state. The band's center is
    ``soc_target`` before and after the step (a flat stretch).
    """
    b = out.shape[0]
    terms = np.empty((b, len(REWARD_TERMS)))
    total = np.empty(b)
    target = np.ascontiguousarray(np.broadcast_to(np.asarray(soc_target, dtype=np.float64), (b,)))
    after = np.ascontiguousarray(state_after, dtype=np.float64)
    w, out = params.weights(lhv_j_per_g, **switches), np.ascontiguousarray(out, dtype=np.float64)
    if state_before is None:  # at the target
        before = np.zeros((b, core.N_STATE))
        before[:, core.SOC] = target
    else:
        before = np.asarray(state_before, dtype=np.float64)
        if before.ndim == 1:  # one state for every row
            before = np.broadcast_to(before, (b, before.size))
        if before.shape != after.shape:
            raise ValueError(f"state_before: shape {before.shape} does not match state_after {after.shape}")
        before = np.ascontiguousarray(before)
    reward_kernel(w, out, before, after, target, target, float(dt_s), terms, total)
    return terms, total


def stage_cost_g(params: RewardParams, out: np.ndarray, state_after: np.ndarray, soc_target: np.ndarray | float,
                 lhv_j_per_g: float, dt_s: float, *, battery: bool = True, soc_deviation: bool = False,
                 overheat: bool = False, soc_band: bool = True, state_before: np.ndarray | None = None) -> np.ndarray:
    """Cost (fuel-equivalent grams, = −reward) of each row of a batch step: what DP and ECMS minimise.

    Always fuel and missed wheel energy; the other terms as switched (:meth:`RewardParams.weights`). ``state_before`` as
    in :func:`reward_terms` (DP charges the settlement on the final SOC instead, :func:`soc_band_charge_g`).
    """
    _, total = reward_terms(params, out, state_after, soc_target, lhv_j_per_g, dt_s, state_before=state_before,
                            battery=battery, soc_deviation=soc_deviation, overheat=overheat, soc_band=soc_band)
    return -total
