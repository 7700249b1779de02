"""The hybrid bus with its motor unused, ADVISOR's parallel electric-assist strategy, and the conventional bus.

``engine_only``
    The hybrid bus driven with u = 0 at every step: the engine carries everything, the friction brakes do all the
    braking. The motor stays in the driveline: its spinning (zero-torque) losses still draw on the battery and heat it.

``conventional``
    Another vehicle, a reference row: the conventional bus (:meth:`VehicleConfig.conventional`: no motor, no
    regeneration, the engine idles instead of stopping), driven with action 0; left out of the comparison with the
    hybrid's optimum.

``rule``
    ADVISOR's charge-sustaining parallel electric-assist control (``PTC_PAR`` defaults), evaluated on the next step's
    coupler-shaft demand T_dem and engine speed ω:

    * engine on when T_dem > ``off_trq_frac``·T_eng,max(ω), or the vehicle speed is at least the electric-launch speed
      (interpolated over SOC between ``launch_spd_lo_mps`` at ``lo_soc`` and ``launch_spd_hi_mps`` at ``hi_soc``), or
      SOC < ``lo_soc``;
    * engine torque T_eng = max(T_dem + T_chg, T_min) with
      T_chg = ``charge_trq_nm``·((lo + hi)/2 − SOC)/((hi − lo)/2) and
      T_min = ``min_trq_frac``·T_eng,max(ω) when SOC < ``lo_soc`` (else 0), capped at the full-load curve (less the
      accessories); the motor takes the rest (u = 1 − T_eng/T_dem, clipped to [-1, 1]);
    * while braking u = 1: the motor takes all the regeneration available, ADVISOR's behaviour.

    With ADVISOR's defaults (``off_trq_frac`` 0, launch speed 0) the engine is on whenever the bus pulls, on purpose.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hev_thermal_env.physics import VehicleConfig, core, engine

from .base import Strategy, register


@register
class EngineOnly(Strategy):
    """The hybrid bus with its motor unused: u = 0 at every step (no assist, no regeneration)."""

    name = "engine_only"
    order = 20
    colour = "#8c564b"
    teacher = True
    in_benchmark = True

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        return np.zeros(1, dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "vehicle": "the hybrid bus, motor unused (no assist, no regeneration)",
                "action": 0.0}


@register
class Conventional(EngineOnly):
    """Another vehicle: the conventional bus (no motor), driven with action 0; a reference row, not compared with the
    hybrid's optimum."""

    name = "conventional"
    order = 10  # another vehicle: the reference row, first
    colour = "#393b79"
    other_vehicle = True

    def vehicle_config(self, config: VehicleConfig) -> VehicleConfig:
        return config.conventional()

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "vehicle": "another vehicle: the conventional bus (VehicleConfig.conventional(): "
                                              "no motor, no regeneration, the engine idling at stops)",
                "action": 0.0, "other_vehicle": True}


@register
class RuleBased(Strategy):
    """ADVISOR's parallel electric-assist control strategy (see the module docstring)."""

    name = "rule"
    order = 30
    colour = "#bcbd22"
    teacher = True
    in_benchmark = True

    def __init__(self, hi_soc: float = 0.7, lo_soc: float = 0.6, launch_spd_lo_mps: float = 0.0,
                 launch_spd_hi_mps: float = 0.0, off_trq_frac: float = 0.0, min_trq_frac: float = 0.4,
                 charge_trq_nm: float | None = None, charge_trq_frac_of_min_max: float = 0.25):
        if not 0.0 < lo_soc < hi_soc < 1.0:
            raise ValueError(f"rule: need 0 < lo_soc < hi_soc < 1, got lo_soc={lo_soc}, hi_soc={hi_soc}")
        self.hi_soc, self.lo_soc, self.off_trq_frac, self.min_trq_frac = (float(hi_soc), float(lo_soc),
                                                                          float(off_trq_frac), float(min_trq_frac))
        self.launch_spd_lo_mps, self.launch_spd_hi_mps = float(launch_spd_lo_mps), float(launch_spd_hi_mps)
        self._charge_trq_nm = self.charge_trq_nm = None if charge_trq_nm is None else float(charge_trq_nm)
        self.charge_trq_frac = float(charge_trq_frac_of_min_max)

    def reset(self, env: Any) -> None:
        super().reset(env)
        if self._charge_trq_nm is None:
            # ADVISOR: cs_charge_trq = 0.25 * min(fc_max_trq)
            self.charge_trq_nm = self.charge_trq_frac * float(min(self.env.config.engine.max_torque_nm))

    def engine_torque_nm(self, demand_nm: float, engine_speed_radps: float, soc: float,
                         speed_mps: float) -> float | None:
        """ADVISOR's engine torque for a positive shaft demand; None means engine off."""
        t_max = float(engine.max_torque_nm(self.env.core.en, engine_speed_radps))
        f = min(max((soc - self.lo_soc) / (self.hi_soc - self.lo_soc), 0.0), 1.0)
        launch = self.launch_spd_lo_mps + f * (self.launch_spd_hi_mps - self.launch_spd_lo_mps)
        on = demand_nm > self.off_trq_frac * t_max or speed_mps >= launch or soc < self.lo_soc
        if not on:
            return None
        mid = 0.5 * (self.lo_soc + self.hi_soc)
        t_chg = self.charge_trq_nm * (mid - soc) / (0.5 * (self.hi_soc - self.lo_soc))
        t_min = self.min_trq_frac * t_max if soc < self.lo_soc else 0.0
        return max(demand_nm + t_chg, t_min)

    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        env = self.env
        _, out = env.peek(np.zeros(1))  # the next step's shaft demand and engine speed do not depend on u
        demand = float(out[0, core.SHAFT_DEMAND])
        if demand < 0.0:
            return np.ones(1, dtype=np.float32)  # braking: all the regeneration available
        if demand == 0.0:
            return np.zeros(1, dtype=np.float32)  # standing: the action has no effect
        soc = float(env.phys_state[0, core.SOC])
        speed = float(env.cycle.speed_mps[env.k])
        t_eng = self.engine_torque_nm(demand, float(out[0, core.ENGINE_SPEED]), soc, speed)
        # the engine gives at most its full-load torque (less the accessories); the motor the rest
        u = 1.0 if t_eng is None else 1.0 - min(t_eng, float(out[0, core.ENGINE_MAX])) / demand
        return np.array([min(max(u, -1.0), 1.0)], dtype=np.float32)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "hi_soc": self.hi_soc, "lo_soc": self.lo_soc,
                "launch_spd_lo_mps": self.launch_spd_lo_mps, "launch_spd_hi_mps": self.launch_spd_hi_mps,
                "off_trq_frac": self.off_trq_frac, "min_trq_frac": self.min_trq_frac,
                "charge_trq_nm": self.charge_trq_nm,
                "note": "ADVISOR PTC_PAR defaults: off_trq_frac 0 and launch speed 0 keep the engine on "
                        "whenever the bus pulls"}
