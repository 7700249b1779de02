"""Battery pack: open-circuit voltage and internal resistance over SOC, power limits, SOC window.

Equivalent circuit: terminal power P = V_oc·I − R·I² (I > 0 discharging). ``n_series`` ADVISOR Ovonic 45 Ah NiMH
modules (ESS_NIMH45_OVONIC at 22 °C) in a string, ``n_parallel`` strings, sized for the 90 kW motor (> 100 kW pulse).
The physics enforces the SOC window: the current allowed in a step never takes the SOC past ``soc_min``/``soc_max``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .jit import jit
from .params import Layout, Params, Slot, spec

N_SOC = 11  # Voc and R tables over SOC 0, 0.1, ..., 1


@dataclasses.dataclass(frozen=True)
class BatteryParams(Params):
    """NiMH pack; module data from ADVISOR ESS_NIMH45_OVONIC (22 °C row)."""

    n_series: int = spec(30, "modules per string", min=1)
    n_parallel: int = spec(2, "parallel strings", min=1)
    module_capacity_ah: float = spec(45.0, "module capacity", min=0.0, min_exclusive=True)
    module_voc_v: tuple = spec((12.5, 12.8, 13.1, 13.3, 13.4, 13.4, 13.5, 13.6, 13.7, 13.9, 14.2),
                               "module open-circuit voltage at SOC 0, 0.1, ..., 1", min=0.0)
    module_r_discharge_ohm: tuple = spec(
        (0.02135, 0.01155, 0.01086, 0.01011, 0.0099, 0.0097, 0.00958, 0.00981, 0.0105, 0.01125, 0.01071),
        "module resistance discharging at SOC 0, 0.1, ..., 1", min=0.0)
    module_r_charge_ohm: tuple = spec(
        (0.02135, 0.01155, 0.01086, 0.01011, 0.0099, 0.0097, 0.00958, 0.00981, 0.0105, 0.01125, 0.01071),
        "module resistance charging at SOC 0, 0.1, ..., 1", min=0.0)
    module_mass_kg: float = spec(8.4, "module mass", min=0.0)
    soc_min: float = spec(0.4, "hard lower SOC bound enforced by the physics", min=0.0, max=1.0)
    soc_max: float = spec(0.8, "hard upper SOC bound enforced by the physics", min=0.0, max=1.0)
    max_discharge_power_w: float = spec(130e3, "terminal discharge power limit", min=0.0)
    max_charge_power_w: float = spec(110e3, "terminal charge power limit", min=0.0)
    coulombic_efficiency: float = spec(0.975, "share of the charging current's charge that is stored (ADVISOR "
                                              "ESS_NIMH45_OVONIC 0.975; NIMH93 1.0)", min=0.95, max=1.0)

    def validate(self) -> None:
        self.require(self.soc_min < self.soc_max, "soc_min", f"the SOC window is inverted or empty "
                     f"(soc_min={self.soc_min} >= soc_max={self.soc_max})")
        for name in ("module_voc_v", "module_r_discharge_ohm", "module_r_charge_ohm"):
            self.require(len(getattr(self, name)) == N_SOC, name, f"need {N_SOC} values (SOC 0 to 1 by 0.1)")
        if not isinstance(self.n_series, int) or not isinstance(self.n_parallel, int):
            object.__setattr__(self, "n_series", int(self.n_series))
            object.__setattr__(self, "n_parallel", int(self.n_parallel))

    @property
    def capacity_ah(self) -> float:
        return self.module_capacity_ah * self.n_parallel

    @property
    def nominal_energy_kwh(self) -> float:
        return self.capacity_ah * self.module_voc_v[5] * self.n_series / 1000.0


LAYOUT = BatteryParams.LAYOUT = Layout(BatteryParams, (
    Slot("capacity_as", fill=lambda p: p.capacity_ah * 3600.0, fields=("module_capacity_ah", "n_parallel")),
    Slot("soc_min"),
    Slot("soc_max"),
    Slot("max_discharge_power_w"),
    Slot("max_charge_power_w"),
    Slot("coulombic_efficiency"),
    Slot("voc_v", N_SOC, fill=lambda p: np.asarray(p.module_voc_v) * p.n_series, fields=("module_voc_v", "n_series")),
    Slot("r_discharge_ohm", N_SOC, fill=lambda p: np.asarray(p.module_r_discharge_ohm) * p.n_series / p.n_parallel,
         fields=("module_r_discharge_ohm",)),
    Slot("r_charge_ohm", N_SOC, fill=lambda p: np.asarray(p.module_r_charge_ohm) * p.n_series / p.n_parallel,
         fields=("module_r_charge_ohm",)),
), unpacked=("module_mass_kg",))  # the module data scaled to the pack
IDX = LAYOUT.index()


@jit
def _table(ba, start, soc):
    x = min(max(soc, 0.0), 1.0) * (N_SOC - 1)
    k = min(int(x), N_SOC - 2)
    f = x - k
    return ba[start + k] + f * (ba[start + k + 1] - ba[start + k])


@jit
def open_circuit_voltage_v(ba, soc):
    return _table(ba, IDX.voc_v, soc)


@jit
def resistance_ohm(ba, soc, charging):
    return _table(ba, IDX.r_charge_ohm if charging else IDX.r_discharge_ohm, soc)


@jit
def power_limits_w(ba, soc, dt_s):
    """(max discharge, max charge) terminal power this step, within rating and the SOC window."""
    voc = open_circuit_voltage_v(ba, soc)
    r_d = resistance_ohm(ba, soc, False)
    r_c = resistance_ohm(ba, soc, True)
    i_dis = max(soc - ba[IDX.soc_min], 0.0) * ba[IDX.capacity_as] / dt_s
    i_dis = min(i_dis, voc / (2.0 * r_d))  # past the matched-load current power falls
    p_dis = min(ba[IDX.max_discharge_power_w], voc * i_dis - r_d * i_dis * i_dis)
    i_chg = max(ba[IDX.soc_max] - soc, 0.0) * ba[IDX.capacity_as] / (dt_s * ba[IDX.coulombic_efficiency])
    p_chg = min(ba[IDX.max_charge_power_w], voc * i_chg + r_c * i_chg * i_chg)
    return max(p_dis, 0.0), max(p_chg, 0.0)


@jit
def current_a(ba, soc, terminal_power_w):
    """Current for a terminal power (positive discharging), from P = V_oc·I − R·I²."""
    voc = open_circuit_voltage_v(ba, soc)
    if terminal_power_w >= 0.0:
        r = resistance_ohm(ba, soc, False)
        disc = voc * voc - 4.0 * r * terminal_power_w
        if disc < 0.0:
            disc = 0.0
        return (voc - math.sqrt(disc)) / (2.0 * r)
    r = resistance_ohm(ba, soc, True)
    return (voc - math.sqrt(voc * voc - 4.0 * r * terminal_power_w)) / (2.0 * r)


@jit
def soc_step(ba, soc, current, dt_s):
    """SOC after ``dt_s`` at ``current`` (coulomb counting; a charging current stores its coulombic efficiency's
    share), held inside the hard window."""
    stored = current if current >= 0.0 else current * ba[IDX.coulombic_efficiency]
    new = soc - stored * dt_s / ba[IDX.capacity_as]
    return min(max(new, ba[IDX.soc_min]), ba[IDX.soc_max])
