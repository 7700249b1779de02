"""Named scenarios: the run conditions (and how they are randomised) for the same vehicle; what each is for and does:
docs/scenarios.md. A scenario is a small record of deltas (:data:`SCENARIOS`), not a code path; a runner calls
:meth:`Scenario.prepare_cycle` on the cycle before building the episode (the conditions alone do not carry the road).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .cycles import load_cycle, with_grade_profile
from .cycles.families import PAYLOAD_KG_RANGE
from .cycles.generator import HILLY_KWARGS, HILLY_SEED
from .physics.config import Conditions


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A named set of run conditions; ``randomized`` scenarios draw new ones each episode. ``grade_profile``: keyword
    arguments of :func:`~hev_thermal_env.cycles.with_grade_profile` (``seed`` and the profile's) for a hilly road;
    ``payload_kg_range``: (low, high) of a payload drawn uniformly per episode after the other draws (randomized)."""

    name: str
    description: str
    conditions: Conditions
    randomized: bool = False
    grade_profile: dict[str, Any] | None = None
    payload_kg_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.payload_kg_range is not None:
            lo, hi = (float(x) for x in self.payload_kg_range)
            if not (self.randomized and 0.0 <= lo <= hi):
                raise ValueError(f"scenario {self.name!r}: payload_kg_range {self.payload_kg_range!r} needs "
                                 f"randomized=True and 0 <= low <= high")

    def sample(self, rng: np.random.Generator) -> Conditions:
        """The conditions of one episode: the fixed ones, or drawn from ``rng`` (the env's ``np_random``)."""
        if not self.randomized:
            return self.conditions
        ambient = float(rng.uniform(10.0, 40.0))
        motor, soc, draw = ambient + float(rng.uniform(0.0, 30.0)), float(rng.uniform(0.55, 0.75)), rng.random()
        if draw < 0.6:
            coolant, factor = "on", 0.1
        elif draw < 0.9:
            coolant, factor = "degraded", float(rng.uniform(0.05, 0.5))
        else:
            coolant, factor = "degraded", 0.01
        cond = Conditions(ambient_temp_c=ambient, initial_motor_temp_c=motor, initial_soc=soc, coolant=coolant,
                          coolant_degraded_factor=factor, coolant_temp_c=ambient + 5.0)
        if self.payload_kg_range is not None:
            cond = cond.replace(payload_kg=float(rng.uniform(*self.payload_kg_range)))
        return cond

    def prepare_cycle(self, cycle: Any) -> Any:
        """The cycle this scenario drives: ``cycle`` itself, or laid over the scenario's road profile (a cycle that
        already has a grade keeps it)."""
        cyc = load_cycle(cycle)
        if self.grade_profile is None or np.any(np.asarray(cyc.grade) != 0.0):
            return cyc
        kwargs = dict(self.grade_profile)
        return with_grade_profile(cyc, kwargs.pop("seed"), **kwargs)


#: The hilly scenarios' road: rolling hills laid under the cycle (:func:`~hev_thermal_env.cycles.with_grade_profile`).
HILLY_ROAD = {"seed": HILLY_SEED, **HILLY_KWARGS}


def in_service(ambient_c: float, warm_c: float, pump: float, fan: bool = True,
               payload_kg: float = 4500.0) -> Conditions:
    """A bus (full: 4.5 t) in ``ambient_c`` air whose motor and coolant start at ``warm_c`` (warm from service), the
    pump's flow at ``pump`` of intact."""
    return Conditions(ambient_temp_c=ambient_c, initial_motor_temp_c=warm_c, coolant_temp_c=warm_c,
                      coolant="degraded", coolant_degraded_factor=pump, payload_kg=payload_kg, fan=fan)


SCENARIOS: dict[str, Scenario] = {
    "paper": Scenario("paper", "the paper's assumptions: 20 °C, coolant on", Conditions()),
    "hot": Scenario("hot", "hot ambient (40 °C), hot start (50 °C), pump flow at 3 % (a failing loop)",
                    Conditions(ambient_temp_c=40.0, initial_motor_temp_c=50.0, coolant="degraded",
                               coolant_degraded_factor=0.03, coolant_temp_c=45.0)),
    "summer": Scenario("summer", "summer day: 38 °C ambient, motor and coolant start at 38 °C, cooling intact",
                       Conditions(ambient_temp_c=38.0, initial_motor_temp_c=38.0)),
    "hilly": Scenario("hilly", "the paper's conditions on a hilly road (grades up to ±7 %, no net climb)",
                      Conditions(), grade_profile=HILLY_ROAD),
    "full_bus": Scenario("full_bus", "the paper's conditions with 4.5 t of passengers (19.5 t in all)",
                         Conditions(payload_kg=4500.0)),
    "weak_loop": Scenario("weak_loop", "a full bus an hour into service: 40 °C air, motor and coolant at 55 °C, "
                                       "pump flow at 10 % (a weak loop)", in_service(40.0, 55.0, 0.1)),
    "hilly_weak_loop": Scenario("hilly_weak_loop", "weak_loop on a hilly road: a full bus an hour into service, 40 °C "
                                "air, motor and coolant at 55 °C, pump flow at 10 %", in_service(40.0, 55.0, 0.1),
                                grade_profile=HILLY_ROAD),
    "hilly_evening": Scenario("hilly_evening", "a hilly road late in a hot day's service: a full bus, 35 °C air, motor "
                              "and coolant at 58 °C, pump flow at 10 %", in_service(35.0, 58.0, 0.1),
                              grade_profile=HILLY_ROAD),
    "hilly_fan_failed": Scenario("hilly_fan_failed", "a hilly road with the radiator's fan failed: a full bus, 40 °C "
                                 "air, motor and coolant at 58 °C, pump flow at 20 %",
                                 in_service(40.0, 58.0, 0.2, fan=False), grade_profile=HILLY_ROAD),
    "random": Scenario("random", "randomised ambient, start temperature, SOC and cooling (training)",
                       Conditions(), randomized=True),
    "random_service": Scenario("random_service", "as random, plus a payload of 0-4.5 t per episode (training)",
                               Conditions(), randomized=True, payload_kg_range=PAYLOAD_KG_RANGE),
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
