"""The prices that put every strategy on equal service: battery and missed wheel energy in fuel grams.

One configurable place for the env's reward, DP and ECMS (through the reward) and the corrected-fuel metric, so a
strategy is optimised for exactly the metric it is judged by. See docs/metrics.md, *Corrected fuel*.
"""

from __future__ import annotations

import dataclasses

from .physics.params import Params, spec


@dataclasses.dataclass(frozen=True)
class Prices(Params):
    """Stated average efficiencies behind the fuel prices of battery and missed wheel energy."""

    engine_efficiency: float = spec(0.36, "average engine efficiency (near FC_CI119's best BSFC, ≈225 g/kWh)",
                                    min=0.05, max=1.0)
    charge_path_efficiency: float = spec(0.90, "motor as generator × battery, charging", min=0.05, max=1.0)
    discharge_path_efficiency: float = spec(0.90, "battery × motor, motoring", min=0.05, max=1.0)
    driveline_efficiency: float = spec(0.93, "gearbox × final drive", min=0.05, max=1.0)

    def battery_g_per_j(self, lhv_j_per_g: float) -> float:
        """Fuel (g) equivalent to one joule of battery chemical energy: what the engine burns to put it back."""
        return 1.0 / (lhv_j_per_g * self.engine_efficiency * self.charge_path_efficiency)

    def miss_g_per_j(self, lhv_j_per_g: float) -> float:
        """Fuel (g) per joule of missed wheel energy: delivered from the battery, put back by the engine."""
        return 1.0 / (lhv_j_per_g * self.engine_efficiency * self.charge_path_efficiency
                      * self.discharge_path_efficiency * self.driveline_efficiency)

    def equivalence_factor(self) -> float:
        """ECMS's s in fuel + s·E_batt/Q_lhv that matches the battery price."""
        return self.battery_g_per_j(1.0)

    def corrections_g(self, battery_energy_j: float, missed_wheel_energy_j: float,
                      lhv_j_per_g: float) -> tuple[float, float]:
        """Fuel (g) equivalent to the net battery energy used and to the missed wheel energy."""
        return (battery_energy_j * self.battery_g_per_j(lhv_j_per_g),
                missed_wheel_energy_j * self.miss_g_per_j(lhv_j_per_g))
