"""Named scenarios: the run conditions (and how they are randomised) for the same vehicle.

* ``paper``: the paper's assumptions. Ambient and motor at 20 °C, coolant on (3000 W/(m²·K),
  perfect radiator), SOC 0.65.
* ``hot``: a hot day with a failing cooling loop. Ambient 40 °C, motor starting at 50 °C, coolant
  degraded to 3 % of its heat transfer with water at 45 °C. A thermal-blind aggressive split
  derates and reaches the 70 °C cutoff on HWFET and on ``beijing``; the engine alone (u = 0) does not,
  so a thermally aware strategy can avoid it at a price in fuel.
* ``random``: for training. Each episode draws ambient 10-40 °C, motor start ambient + 0-30 °C,
  SOC 0.55-0.75 and the coolant on (60 %), degraded (30 %) or nearly failed (10 %), all from
  the env's ``np_random``.

A scenario is a small record of deltas, not a code path (DESIGN §2, STYLE.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .physics.config import Conditions


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A named set of run conditions; ``randomized`` scenarios draw new ones each episode."""

    name: str
    description: str
    conditions: Conditions
    randomized: bool = False

    def sample(self, rng: np.random.Generator) -> Conditions:
        """The conditions of one episode (the fixed ones unless ``randomized``)."""
        if not self.randomized:
            return self.conditions
        ambient = float(rng.uniform(10.0, 40.0))
        motor = ambient + float(rng.uniform(0.0, 30.0))
        soc = float(rng.uniform(0.55, 0.75))
        draw = rng.random()
        if draw < 0.6:
            coolant, factor = "on", 0.1
        elif draw < 0.9:
            coolant, factor = "degraded", float(rng.uniform(0.05, 0.5))
        else:
            coolant, factor = "degraded", 0.01
        return Conditions(ambient_temp_c=ambient, initial_motor_temp_c=motor, initial_soc=soc, coolant=coolant,
                          coolant_degraded_factor=factor, coolant_temp_c=ambient + 5.0)


SCENARIOS: dict[str, Scenario] = {
    "paper": Scenario("paper", "the paper's assumptions: 20 °C, coolant on", Conditions()),
    "hot": Scenario("hot", "hot ambient (40 °C), hot start (50 °C), cooling degraded to 3 %",
                    Conditions(ambient_temp_c=40.0, initial_motor_temp_c=50.0, coolant="degraded",
                               coolant_degraded_factor=0.03, coolant_temp_c=45.0)),
    "random": Scenario("random", "randomised ambient, start temperature, SOC and cooling (training)",
                       Conditions(), randomized=True),
}


def list_scenarios() -> list[str]:
    return list(SCENARIOS)


def get_scenario(name: str | Scenario) -> Scenario:
    """A scenario by name; an unknown name lists the known ones."""
    if isinstance(name, Scenario):
        return name
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; known scenarios: {', '.join(SCENARIOS)}") from None
