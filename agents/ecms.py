"""Equivalent consumption minimisation: ``ecms``, ``aecms`` (adaptive) and ``ecms_thermal``.

Every step one ``env.peek`` call evaluates a grid of splits u ∈ [-1, 1] (41 by default) for the next step, and the
cheapest wins, in traction and while braking alike (there u > 0 is the share of the available regeneration and u ≤ 0
friction alone: the tie goes to u = 0)::

    J(u) = fuel_g + s_eff · E_batt / Q_lhv + miss price

E_batt: the battery's chemical energy over the step (J, negative when charging); Q_lhv: the fuel's lower heating value;
the miss price is the reward's. s = :data:`REWARD_EQUIVALENCE_FACTOR` (≈3.09) prices battery energy as the reward and
the corrected fuel do.

* ``ecms``: s_eff = s · (1 + k · ((SOC_target − SOC)/0.1)^p), p = 1 (``penalty="linear"``) or 3 (``"cubic"``).
* ``aecms``: s_eff = s0 + k_p·e + k_i·∫e dt, e = SOC_target − SOC (PI; the integral clamped, anti-windup).
* ``ecms_thermal``: ``ecms`` plus a price on the peeked next thermal state (w_x, x_thr and w_temp by the env's physics
  version unless given, :data:`THERMAL_PRICES`): w_x · max(x' − x_thr, 0) (heat-index integrator x, eq 9) +
  w_T · max(T' − T_soft, 0)² + w_cut · [cut off]'. With ``x_price="margin"`` the heat-index price is
  w_x · max(floor, min(1, ΔT_h / (T_cut − T))), ΔT_h = T_cut − T_release the cutoff's hysteresis band (10 K), floor
  ``margin_floor``; while the bus brakes, ``braking_x_thr`` and ``braking_floor`` (by default x_thr and margin_floor)
  take their place, with ``braking_below_c`` only while the motor is cooler than that (docs/strategies.md,
  "ecms_thermal's heat-index price"; docs/training.md, "Regeneration priced where it derates").

Tuning (one setting for both cycle families): s = 2.9, k = 1 (linear); A-ECMS s0 = 2.9, k_p = 20, k_i = 0.01 1/s, end
``beijing`` (``paper``) at ΔSOC ≈ +0.005 within 0.1 % of DP's corrected fuel.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hev_thermal_env.envs.reward import RewardParams, stage_cost_g
from hev_thermal_env.physics import core
from hev_thermal_env.physics.config import LATEST_PHYSICS
from hev_thermal_env.planning.problem import argmin_small_action
from hev_thermal_env.prices import Prices

from .base import Strategy, register

#: ``ecms_thermal``'s heat-index prices: ``fixed`` (w_x) and ``margin`` (w_x scaled by the distance to the cutoff).
X_PRICES = ("fixed", "margin")
#: ``ecms_thermal``'s heat prices by physics version when left out (the env's physics version decides at reset). v1
#: keeps the motor out of derating: 300 g per unit of the heat-index integrator from x = −0.05, 5 g/K² above 55 °C;
#: v2: 30 g per unit of the heat index PWM itself (x > 0), no temperature price (docs/strategies.md, "ecms_thermal on
#: physics v2").
THERMAL_PRICES = {1: {"w_x": 300.0, "x_thr": -0.05, "w_temp": 5.0},
                  2: {"w_x": 30.0, "x_thr": 0.0, "w_temp": 0.0}}
#: The equivalence factor (s in fuel + s·E_batt/Q_lhv) that matches the reward's default battery price.
REWARD_EQUIVALENCE_FACTOR = Prices().equivalence_factor()


def ecms_cost_g(out: np.ndarray, state_after: np.ndarray, s_eff: float, lhv_j_per_g: float,
                reward_params: RewardParams, dt_s: float = 1.0) -> np.ndarray:
    """ECMS cost (fuel-equivalent g) of each candidate row: fuel + s_eff·E_batt/Q_lhv + miss price."""
    base = stage_cost_g(reward_params, out, state_after, 0.0, lhv_j_per_g, dt_s, battery=False)
    return base + s_eff * out[:, core.BATT_CHEM] * dt_s / lhv_j_per_g


@register
class ECMS(Strategy):
    """Equivalent consumption minimisation with an SOC penalty on the equivalence factor."""

    name = "ecms"
    order = 40
    colour = "#1f77b4"
    teacher = True
    in_benchmark = True

    def __init__(self, s: float = 2.9, k_soc: float = 1.0, penalty: str = "linear", n_u: int = 41,
                 soc_target: float | None = None):
        if penalty not in ("cubic", "linear"):
            raise ValueError(f"{self.name}: penalty {penalty!r} is not one of ['cubic', 'linear']")
        if n_u < 2:
            raise ValueError(f"{self.name}: n_u must be at least 2, got {n_u}")
        self.s, self.k_soc, self.penalty = float(s), float(k_soc), penalty
        self.u_grid = np.linspace(-1.0, 1.0, int(n_u))
        self.soc_target_option = self.soc_target = soc_target
        #: The last step's cost of every candidate above the cheapest (g, over ``u_grid``; zeros while standing): what
        #: a student's action costs by the strategy's own measure (``init.cost_weight``, docs/training.md).
        self.cost_curve_g: np.ndarray | None = None

    def reset(self, env: Any) -> None:
        super().reset(env)
        self.soc_target = float(self.env.soc_target if self.soc_target_option is None else self.soc_target_option)
        self.lhv = self.env.config.engine.fuel_lhv_j_per_g
        self.dt_s = self.env.core.dt_s
        self.engine_off_from = self.env.config.powertrain.engine_off_from

    def equivalence_factor(self, soc: float) -> float:
        e = (self.soc_target - soc) / 0.1
        p = e ** 3 if self.penalty == "cubic" else e
        return self.s * (1.0 + self.k_soc * p)

    def candidate_costs(self, state_after: np.ndarray, out: np.ndarray, soc: float) -> np.ndarray:
        return ecms_cost_g(out, state_after, self.equivalence_factor(soc), self.lhv, self.env.reward_params,
                           self.dt_s)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        env = self.env
        soc = float(env.phys_state[0, core.SOC])
        st, out = env.peek(self.u_grid)
        self._observe(soc)
        if out[0, core.SHAFT_DEMAND] == 0.0:
            self.cost_curve_g = np.zeros(len(self.u_grid))
            return np.zeros(1, dtype=np.float32)  # standing: the action has no effect
        cost = self.candidate_costs(st, out, soc)
        self.cost_curve_g = cost - cost.min()
        best = argmin_small_action(cost, self.u_grid, engine_off_from=self.engine_off_from)
        return np.array([self.u_grid[best]], dtype=np.float32)

    def _observe(self, soc: float) -> None:
        """Hook for adaptive variants (called once per step with the SOC before the step)."""

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "equivalence_factor": self.s, "soc_penalty": self.penalty, "k_soc": self.k_soc,
                "soc_target": self.soc_target, "n_u": len(self.u_grid),
                "reward_equivalence_factor": REWARD_EQUIVALENCE_FACTOR}


@register
class AdaptiveECMS(ECMS):
    """A-ECMS: the equivalence factor follows a PI controller on the SOC error."""

    name = "aecms"
    order = 50
    colour = "#17becf"

    def __init__(self, s0: float = 2.9, kp: float = 20.0, ki: float = 0.01, integral_limit: float = 20.0,
                 n_u: int = 41, soc_target: float | None = None):
        super().__init__(s=s0, k_soc=0.0, penalty="linear", n_u=n_u, soc_target=soc_target)
        self.kp, self.ki, self.integral_limit, self.integral = float(kp), float(ki), float(integral_limit), 0.0

    def reset(self, env: Any) -> None:
        super().reset(env)
        self.integral = 0.0

    def _observe(self, soc: float) -> None:
        e = self.soc_target - soc
        self.integral = min(max(self.integral + e * self.dt_s, -self.integral_limit), self.integral_limit)

    def equivalence_factor(self, soc: float) -> float:
        return max(self.s + self.kp * (self.soc_target - soc) + self.ki * self.integral, 0.0)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "s0": self.s, "kp": self.kp, "ki": self.ki, "integral_limit_s": self.integral_limit,
                "soc_target": self.soc_target, "n_u": len(self.u_grid),
                "reward_equivalence_factor": REWARD_EQUIVALENCE_FACTOR}


@register
class ThermalECMS(ECMS):
    """ECMS that also prices the next heat index, temperature and cutoff (avoids derating and cutoff)."""

    name = "ecms_thermal"
    order = 60
    colour = "#9467bd"
    thermal_aware = True

    def __init__(self, s: float = 2.9, k_soc: float = 1.0, penalty: str = "linear", n_u: int = 41,
                 soc_target: float | None = None, w_x: float | None = None, x_thr: float | None = None,
                 w_temp: float | None = None, temp_soft_c: float = 55.0, w_cutoff: float = 1000.0,
                 x_price: str = "fixed", margin_floor: float = 0.0, braking_floor: float | None = None,
                 braking_x_thr: float | None = None, braking_below_c: float | None = None):
        super().__init__(s=s, k_soc=k_soc, penalty=penalty, n_u=n_u, soc_target=soc_target)
        if x_price not in X_PRICES:
            raise ValueError(f"{self.name}: x_price {x_price!r} is not one of {list(X_PRICES)}")
        for key, floor in (("margin_floor", margin_floor), ("braking_floor", braking_floor or 0.0)):
            if not 0.0 <= float(floor) <= 1.0:
                raise ValueError(f"{self.name}: {key} must lie in [0, 1] (a share of w_x), got {floor!r}")
            if x_price != "margin" and float(floor) != 0.0:
                raise ValueError(f"{self.name}: {key} applies to x_price='margin', not {x_price!r}")
        self.x_price = x_price
        self.margin_floor = float(margin_floor)
        self.braking_floor = self.margin_floor if braking_floor is None else float(braking_floor)
        if braking_x_thr is not None and not -0.3 <= float(braking_x_thr) <= 0.0:
            raise ValueError(f"{self.name}: braking_x_thr must lie in [-0.3, 0] (the heat-index integrator x), got "
                             f"{braking_x_thr!r}")
        if braking_below_c is not None and not math.isfinite(float(braking_below_c)):
            raise ValueError(f"{self.name}: braking_below_c must be a finite temperature (°C), got {braking_below_c!r}")
        self.braking_below_c = None if braking_below_c is None else float(braking_below_c)
        self.temp_soft_c, self.w_cutoff = float(temp_soft_c), float(w_cutoff)
        self._given = {"w_x": w_x, "x_thr": x_thr, "w_temp": w_temp, "braking_x_thr": braking_x_thr}
        self._set_prices(LATEST_PHYSICS)

    def _set_prices(self, physics: int) -> None:
        """``w_x``, ``x_thr``, ``w_temp`` as given, else :data:`THERMAL_PRICES` of ``physics``; ``braking_x_thr``
        follows ``x_thr`` unless given."""
        given = self._given
        prices = {k: float(v if given[k] is None else given[k]) for k, v in THERMAL_PRICES[physics].items()}
        self.w_x, self.x_thr, self.w_temp = prices["w_x"], prices["x_thr"], prices["w_temp"]
        self.braking_x_thr = self.x_thr if given["braking_x_thr"] is None else float(given["braking_x_thr"])

    def reset(self, env: Any) -> None:
        super().reset(env)
        self._set_prices(int(getattr(self.env, "physics", LATEST_PHYSICS)))
        th = self.env.config.thermal
        self.cutoff_c, self.band_k = th.cutoff_temp_c, th.cutoff_temp_c - th.cutoff_release_temp_c

    def heat_index_terms(self, braking: bool = False) -> tuple[float, float]:
        """The heat index's price and the x it is priced from, at the present temperature: w_x, or with
        ``x_price="margin"`` w_x · max(floor, min(1, ΔT_h / (T_cut − T))), from ``x_thr`` with the floor
        ``margin_floor``; while the bus brakes (``braking``), and with ``braking_below_c`` only in a motor cooler than
        that, from ``braking_x_thr`` with the floor ``braking_floor``."""
        temp_c = float(self.env.phys_state[0, core.TEMP_C])
        own = braking and (self.braking_below_c is None or temp_c < self.braking_below_c)
        x_thr = self.braking_x_thr if own else self.x_thr
        if self.x_price == "fixed":
            return self.w_x, x_thr
        floor = self.braking_floor if own else self.margin_floor
        return self.w_x * max(floor, min(1.0, self.band_k / max(self.cutoff_c - temp_c, 1e-9))), x_thr

    def heat_index_price(self, braking: bool = False) -> float:
        """The heat index's price (:meth:`heat_index_terms`)."""
        return self.heat_index_terms(braking)[0]

    def candidate_costs(self, state_after: np.ndarray, out: np.ndarray, soc: float) -> np.ndarray:
        """ECMS's cost plus the price of the next thermal state (heat index, temperature, cutoff)."""
        over = np.maximum(state_after[:, core.TEMP_C] - self.temp_soft_c, 0.0)
        price, x_thr = self.heat_index_terms(bool(out[0, core.SHAFT_DEMAND] < 0.0))
        heat = (price * np.maximum(state_after[:, core.HEAT_X] - x_thr, 0.0)
                + self.w_temp * over * over + self.w_cutoff * state_after[:, core.CUTOFF])
        return super().candidate_costs(state_after, out, soc) + heat

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "w_x_g": self.w_x, "x_thr": self.x_thr, "w_temp_g_per_k2": self.w_temp,
                "temp_soft_c": self.temp_soft_c, "w_cutoff_g": self.w_cutoff, "x_price": self.x_price,
                "margin_floor": self.margin_floor, "braking_floor": self.braking_floor,
                "braking_x_thr": self.braking_x_thr, "braking_below_c": self.braking_below_c}
