"""Episodes: what is drawn at reset (cycle, conditions, start) and the per-cycle tables the steps read."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..cycles import Cycle, expand_cycle_names, generate_family_cycle, load_cycle
from ..cycles.families import training_seed
from ..cycles.names import is_family
from ..physics.config import COOLANT_MODES, Conditions
from ..physics.core import GEAR, WHEEL_DEMAND, PhysicsCore
from ..scenarios import Scenario, get_scenario

#: The largest ``soc_offset`` an env takes (SOC).
MAX_SOC_OFFSET = 0.2
#: Keys accepted in ``reset(options=...)``.
RESET_OPTIONS = ("cycle", "ambient_temp_c", "initial_motor_temp_c", "initial_soc", "coolant", "start_s")


def check_soc_offset(value: Any, where: str = "soc_offset") -> float:
    """``value`` as a ``soc_offset`` (a number in [0, :data:`MAX_SOC_OFFSET`]), or a one-line error naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
            or not 0.0 <= float(value) <= MAX_SOC_OFFSET:
        raise ValueError(f"{where}: expected a number in [0, {MAX_SOC_OFFSET}] (SOC), got {value!r}")
    return float(value)


class CycleChoice:
    """What the env's ``cycle`` argument asks for: fixed cycles (loaded once, here, so errors show at construction)
    and cycle families (a fresh cycle every episode, seeded by :func:`~hev_thermal_env.cycles.families.training_seed`),
    one drawn uniformly per episode, laid over the scenario's road if it has one (:meth:`Scenario.prepare_cycle`).
    """

    def __init__(self, cycle: Any, scenario: Scenario | None = None):
        items = expand_cycle_names(list(cycle) if isinstance(cycle, (list, tuple)) else [cycle])
        if not items:
            raise ValueError("cycle: the list of cycles is empty")
        self.scenario = scenario
        self.items: list[Cycle | str] = []
        for item in items:
            if is_family(item):
                self.items.append(item.strip().lower())
            elif isinstance(item, (str, os.PathLike, Cycle)):
                cyc = load_cycle(item)
                self.items.append(cyc if scenario is None else scenario.prepare_cycle(cyc))
            else:
                raise TypeError(f"cycle: expected a cycle name, a path, a Cycle, a family such as 'random_bus' "
                                f"or a list of these, got {type(item).__name__}")

    def draw(self, rng: np.random.Generator) -> Cycle:
        item = self.items[int(rng.integers(len(self.items)))] if len(self.items) > 1 else self.items[0]
        if isinstance(item, str):
            cyc = generate_family_cycle(item, training_seed(rng, item))
            return cyc if self.scenario is None else self.scenario.prepare_cycle(cyc)
        return item


@dataclasses.dataclass(frozen=True)
class Episode:
    """Everything that is drawn when an episode starts."""

    cycle: Cycle
    conditions: Conditions
    start_s: int
    soc_target: float
    """The SOC the episode's reward and observation hold to: the conditions' initial SOC before any offset."""


class EpisodeSampler:
    """Draws episodes from a generator, in a fixed order (conditions, cycle, random bus seed, start offset, then the
    SOC offset if ``soc_offset`` > 0; the env's spec says what it does), for the single and the vector env: a vector
    sub-env seeded like a single env lives through the same episodes."""

    def __init__(self, cycle: Any, scenario: str | Scenario, conditions: Conditions | None, random_start: bool,
                 soc_offset: float = 0.0, soc_window: tuple[float, float] = (0.0, 1.0)):
        self.scenario = get_scenario(scenario)
        self.cycles = CycleChoice(cycle, self.scenario)
        if conditions is not None and not isinstance(conditions, Conditions):
            raise TypeError(f"conditions: expected Conditions or None, got {type(conditions).__name__}")
        self.conditions, self.random_start = conditions, bool(random_start)
        self.soc_offset, self.soc_window = check_soc_offset(soc_offset), (float(soc_window[0]), float(soc_window[1]))

    def sample(self, rng: np.random.Generator, options: dict[str, Any] | None) -> Episode:
        options = {} if options is None else options
        if not isinstance(options, dict):
            raise TypeError(f"options: expected a dict or None, got {type(options).__name__}")
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ValueError(f"unknown reset option(s) {unknown}; valid options: {list(RESET_OPTIONS)}")
        cond = self.conditions if self.conditions is not None else self.scenario.sample(rng)
        changes = {k: options[k] for k in ("ambient_temp_c", "initial_motor_temp_c", "initial_soc", "coolant")
                   if k in options}
        if "coolant" in changes and changes["coolant"] not in COOLANT_MODES:
            raise ValueError(f"reset option coolant: {changes['coolant']!r} is not one of {list(COOLANT_MODES)}")
        for key, value in changes.items():
            if key != "coolant" and (isinstance(value, bool) or not isinstance(value, (int, float, np.number))):
                raise ValueError(f"reset option {key}: expected a number, got {value!r}")
        if changes:
            cond = cond.replace(**changes)
        choice = CycleChoice(options["cycle"], self.scenario) if "cycle" in options else self.cycles
        cycle = choice.draw(rng)
        if "start_s" in options:
            start = options["start_s"]
            if isinstance(start, bool) or not isinstance(start, (int, float, np.integer, np.floating)) \
                    or start != int(start) or not 0 <= start < cycle.n_steps:
                raise ValueError(f"reset option start_s: {start!r} must be a whole number of seconds in "
                                 f"[0, {cycle.n_steps - 1}] for cycle {cycle.name!r}")
            start = int(start)
        elif self.random_start:
            start = int(rng.integers(cycle.n_steps))
        else:
            start = 0
        target = float(cond.initial_soc)
        if self.soc_offset > 0.0:
            offset = rng.uniform(-self.soc_offset, self.soc_offset)  # drawn in any case: the stream stays the same
            if "initial_soc" not in options:  # a start asked for is the start, and the target
                cond = cond.replace(initial_soc=float(np.clip(target + offset, *self.soc_window)))
        return Episode(cycle, cond, start, target)


class CycleTables:
    """Per-step quantities of a cycle that do not depend on the vehicle's state: the demanded wheel power and the gear
    of each step from one batched call of the physics core over all steps."""

    def __init__(self, core: PhysicsCore, cycle: Cycle, state_row: np.ndarray, cond_row: np.ndarray):
        n = cycle.n_steps
        v = np.array(cycle.speed_mps, dtype=np.float64)
        g = np.array(cycle.grade, dtype=np.float64)
        _, out = core.step(np.repeat(state_row[None, :], n, axis=0), np.zeros(n), v[:-1].copy(), v[1:].copy(),
                           g[:-1].copy(), np.repeat(cond_row[None, :], n, axis=0))
        self.cycle, self.speed_mps, self.grade = cycle, v, g
        self.wheel_power_demand_kw = out[:, WHEEL_DEMAND] / 1000.0
        self.gear = out[:, GEAR].copy()
        rise = 0.5 * (v[:-1] + v[1:]) * core.dt_s * g[:-1] / np.sqrt(1.0 + g[:-1] ** 2)
        #: Height reached at each instant, from the start (m): the climb of each step's distance on its grade.
        self.climb_m = np.concatenate([[0.0], np.cumsum(rise)])


class TableCache:
    """Cycle tables of the env's fixed cycles, kept per (cycle, payload) (the mass changes them); other cycles
    (random, from options) fresh."""

    def __init__(self, core: PhysicsCore, fixed: Sequence[Cycle]):
        self.core = core
        self._fixed = {id(c): c for c in fixed}
        self._cache: dict[tuple[int, float], CycleTables] = {}

    def get(self, ep: Episode) -> CycleTables:
        key = (id(ep.cycle), float(ep.conditions.payload_kg))
        if (tab := self._cache.get(key)) is not None:
            return tab
        st = self.core.initial_state(ep.conditions, 1)[0]
        tab = CycleTables(self.core, ep.cycle, st, self.core.conditions_array(ep.conditions, 1)[0])
        if self._fixed.get(key[0]) is ep.cycle and len(self._cache) < 256:
            self._cache[key] = tab
        return tab


