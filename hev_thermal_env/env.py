"""``HevThermal-v0``: energy management of a parallel hybrid city bus with a thermally limited motor.

The environment is a thin MDP layer over :mod:`hev_thermal_env.physics.core`: every step is one
call of :func:`~hev_thermal_env.physics.core.step_kernel` (through the same batched tables the
native vector environment uses, :class:`EpisodeRows`), the reward is
:func:`hev_thermal_env.reward.reward_terms`, and the run conditions come from
:mod:`hev_thermal_env.scenarios`.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .cycles import Cycle, generate_bus_cycle, load_cycle
from .physics import core as C
from .physics.config import COOLANT_MODES, Conditions, VehicleConfig, paper_bus
from .reward import RewardParams, reward_terms
from .scenarios import Scenario, get_scenario

RPM_PER_RADPS = 30.0 / math.pi

RANDOM_BUS = "random_bus"
"""Cycle name that draws a fresh synthetic bus cycle (``generate_bus_cycle``) every episode."""

RESET_OPTIONS = ("cycle", "ambient_temp_c", "initial_motor_temp_c", "initial_soc", "coolant", "start_s")
"""Keys accepted in ``reset(options=...)``."""

# --- observation layout ---------------------------------------------------------------------------
# (name, low, high, unit, meaning); ``None`` bounds are filled from the vehicle.
_OBS_FIELDS = (
    ("speed_mps", 0.0, 60.0, "m/s", "vehicle speed at the start of the next step (cycle speed)"),
    ("accel_mps2", -10.0, 10.0, "m/s²", "acceleration the cycle demands over the next step"),
    ("wheel_power_demand_kw", -2000.0, 2000.0, "kW", "wheel power the cycle demands over the next step"),
    ("soc", 0.0, 1.0, "-", "battery state of charge"),
    ("soc_target", 0.0, 1.0, "-", "SOC target of the reward (the episode's initial SOC)"),
    ("motor_temp_c", -40.0, 200.0, "°C", "motor temperature"),
    ("heat_index", 0.0, 1.0, "-", "heat index PWM (eq 9): 0 full peak torque, 1 continuous torque only"),
    ("heat_x", -1.0, 1.0, "-", "heat-index integrator state x (eq 9); PWM = clip(x, 0, 1)"),
    ("motor_cutoff", 0.0, 1.0, "-", "1 while the 70 °C protection holds the motor off"),
    ("motor_torque_avail_nm", 0.0, None, "N·m", "motor torque envelope of the last step (at reset: of the first)"),
    ("gear", 1.0, None, "-", "gear of the next step (set by the shift schedule from the cycle)"),
    ("cycle_progress", 0.0, 1.0, "-", "elapsed fraction of the cycle"),
    ("ambient_temp_c", -40.0, 60.0, "°C", "ambient air temperature"),
    ("coolant_factor", 0.0, 1.0, "-", "coolant heat-transfer multiplier: 1 on, <1 degraded, 0 off"),
)
PREVIEW_MAX_MPS = 60.0
(OBS_SPEED, OBS_ACCEL, OBS_DEMAND, OBS_SOC, OBS_SOC_TARGET, OBS_TEMP, OBS_PWM, OBS_HEAT_X, OBS_CUTOFF, OBS_AVAIL,
 OBS_GEAR, OBS_PROGRESS, OBS_AMBIENT, OBS_COOLANT) = range(14)
N_OBS_BASE = len(_OBS_FIELDS)

# --- info layout ----------------------------------------------------------------------------------
# Step-info keys straight from an output column of the physics core.
_INFO_OUT_COLUMNS = (
    ("fuel_g", C.FUEL_G), ("motor_torque_nm", C.MOTOR_TORQUE), ("motor_heat_w", C.MOTOR_HEAT),
    ("engine_torque_nm", C.ENGINE_TORQUE), ("speed_mps", C.SPEED), ("trace_miss_mps", C.TRACE_MISS),
    ("heat_index", C.HEAT_INDEX), ("missed_wheel_energy_j", C.MISSED_J), ("battery_chem_power_w", C.BATT_CHEM),
    ("battery_power_w", C.BATT_POWER), ("motor_torque_avail_nm", C.MOTOR_AVAIL),
)
_INFO_RPM_COLUMNS = (("motor_speed_rpm", C.MOTOR_SPEED), ("engine_speed_rpm", C.ENGINE_SPEED))
_INFO_BOOL_COLUMNS = (("engine_on", C.ENGINE_ON), ("coolant_on", C.COOLANT_ON),
                      ("motor_torque_clipped", C.MOTOR_CLIPPED))
_REWARD_KEYS = ("reward_fuel", "reward_overheat", "reward_soc", "reward_miss")

INFO_KEYS = (
    "fuel_g", "soc", "motor_temp_c", "heat_index", "motor_torque_nm", "motor_speed_rpm", "motor_heat_w",
    "engine_torque_nm", "engine_speed_rpm", "engine_on", "gear", "speed_mps", "trace_miss_mps", "motor_cutoff",
    "coolant_on", *_REWARD_KEYS, "missed_wheel_energy_j", "battery_chem_power_w", "battery_power_w",
    "motor_torque_avail_nm", "cycle_speed_mps", "time_s", "action", "action_clipped", "motor_torque_clipped",
)
"""Keys of the ``info`` dict of every step (DESIGN §4 contract first, then extras)."""

RESET_INFO_KEYS = ("cycle_name", "start_s", "time_s", "soc", "soc_target", "motor_temp_c", "heat_index",
                   "motor_cutoff", "ambient_temp_c", "coolant")
"""Keys of the ``info`` dict returned by ``reset``."""


def observation_names(preview_s: int, preview_step_s: int) -> tuple[str, ...]:
    """Names of the observation entries, in order."""
    offsets = preview_offsets(preview_s, preview_step_s)
    return tuple(f[0] for f in _OBS_FIELDS) + tuple(f"preview_speed_{int(o)}s_mps" for o in offsets)


def preview_offsets(preview_s: int, preview_step_s: int) -> np.ndarray:
    """Seconds ahead of the next step's start at which the preview samples the cycle speed."""
    if preview_s < 0 or preview_step_s < 1 or int(preview_s) != preview_s or int(preview_step_s) != preview_step_s:
        raise ValueError(f"preview_s must be an integer >= 0 and preview_step_s an integer >= 1, got "
                         f"preview_s={preview_s!r}, preview_step_s={preview_step_s!r}")
    return np.arange(int(preview_step_s), int(preview_s) + 1, int(preview_step_s), dtype=np.int64)


def observation_bounds(config: VehicleConfig, n_preview: int) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds (float64) of the observation for ``config``."""
    fill = {"motor_torque_avail_nm": max(config.motor.peak_torque_nm, config.motor.continuous_torque_nm, 1.0),
            "gear": float(len(config.driveline.gear_ratios))}
    low = [f[1] for f in _OBS_FIELDS] + [0.0] * n_preview
    high = [fill.get(f[0], f[2]) for f in _OBS_FIELDS] + [PREVIEW_MAX_MPS] * n_preview
    return np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)


def total_reward(terms: dict[str, np.ndarray]) -> np.ndarray:
    """Sum of the reward terms (fixed order, so single and vector envs agree bit for bit)."""
    return ((terms["reward_fuel"] + terms["reward_miss"]) + terms["reward_soc"]) + terms["reward_overheat"]


# --- episodes -------------------------------------------------------------------------------------

class CycleChoice:
    """What the ``cycle`` argument asks for: fixed cycles (drawn uniformly if several) or random bus cycles.

    Accepts a built-in name, a CSV path, a :class:`Cycle`, ``"random_bus"``, or a non-empty list of these.
    Named and file cycles are loaded once, here, so errors show at construction.
    """

    def __init__(self, cycle: Any):
        items = list(cycle) if isinstance(cycle, (list, tuple)) else [cycle]
        if not items:
            raise ValueError("cycle: the list of cycles is empty")
        self.items: list[Cycle | None] = []
        for item in items:
            if isinstance(item, str) and item.strip().lower() == RANDOM_BUS:
                self.items.append(None)
            elif isinstance(item, (str, os.PathLike, Cycle)):
                self.items.append(load_cycle(item))
            else:
                raise TypeError(f"cycle: expected a cycle name, a path, a Cycle, {RANDOM_BUS!r} or a list of these, "
                                f"got {type(item).__name__}")

    def draw(self, rng: np.random.Generator) -> Cycle:
        item = self.items[int(rng.integers(len(self.items)))] if len(self.items) > 1 else self.items[0]
        if item is None:
            return generate_bus_cycle(int(rng.integers(2**31 - 1)))
        return item

    def fixed_cycles(self) -> list[Cycle]:
        return [c for c in self.items if c is not None]


@dataclasses.dataclass(frozen=True)
class Episode:
    """Everything that is drawn when an episode starts."""

    cycle: Cycle
    conditions: Conditions
    start_s: int


class EpisodeSampler:
    """Draws episodes (conditions, cycle, start) from a generator; shared by the single and vector envs.

    The draws come in a fixed order (conditions, cycle, random bus seed, start offset), so a vector
    sub-environment seeded like a single environment lives through the same episodes.
    """

    def __init__(self, cycle: Any, scenario: str | Scenario, conditions: Conditions | None, random_start: bool):
        self.cycles = CycleChoice(cycle)
        self.scenario = get_scenario(scenario)
        if conditions is not None and not isinstance(conditions, Conditions):
            raise TypeError(f"conditions: expected Conditions or None, got {type(conditions).__name__}")
        self.conditions = conditions
        self.random_start = bool(random_start)

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
        if changes:
            cond = cond.replace(**changes)
        choice = CycleChoice(options["cycle"]) if "cycle" in options else self.cycles
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
        return Episode(cycle, cond, start)


class CycleTables:
    """Per-step quantities of a cycle that do not depend on the vehicle's state.

    The demanded wheel power and the gear of each step come from one batched call of the physics
    core over all steps of the cycle (they depend only on the speed trace, the grade and the vehicle).
    """

    def __init__(self, core: C.PhysicsCore, cycle: Cycle, state_row: np.ndarray, cond_row: np.ndarray):
        n = cycle.n_steps
        v = np.array(cycle.speed_mps, dtype=np.float64)
        g = np.array(cycle.grade, dtype=np.float64)
        _, out = core.step(np.repeat(state_row[None, :], n, axis=0), np.zeros(n), v[:-1].copy(), v[1:].copy(),
                           g[:-1].copy(), np.repeat(cond_row[None, :], n, axis=0))
        self.cycle = cycle
        self.speed_mps = v
        self.grade = g
        self.wheel_power_demand_kw = out[:, C.WHEEL_DEMAND] / 1000.0
        self.gear = out[:, C.GEAR].copy()


class EpisodeRows:
    """Per-row episode tables of a batch of vehicles, each on its own cycle; the step of both envs.

    Each row holds its cycle padded to a common width (speed held at its last value), its step
    index ``k``, end step, state, conditions and SOC target. :meth:`step` advances every row with
    one call of the physics core; :meth:`observe` builds the observations of all rows at once.
    """

    def __init__(self, core: C.PhysicsCore, n_rows: int, offsets: np.ndarray, low: np.ndarray, high: np.ndarray,
                 reward_params: RewardParams):
        self.core = core
        self.rp = reward_params
        self.n = n_rows
        self.offsets = offsets
        self.low = low
        self.high = high
        self.low32 = low.astype(np.float32)[:, None]
        self.high32 = high.astype(np.float32)[:, None]
        self.pad = int(offsets.max()) + 2 if offsets.size else 2
        self.width = 0
        self._alloc(2)
        self.k = np.zeros(n_rows, dtype=np.int64)
        self.end = np.ones(n_rows, dtype=np.int64)
        self.n_steps = np.ones(n_rows, dtype=np.int64)
        self.state = np.zeros((n_rows, C.N_STATE))
        self.cond = np.zeros((n_rows, C.N_COND))
        self.soc_target = np.zeros(n_rows)
        self.avail = np.zeros(n_rows)
        self.last_out = np.zeros((n_rows, C.N_OUT))
        self.cycles: list[Cycle | None] = [None] * n_rows
        self.conditions: list[Conditions | None] = [None] * n_rows
        self.lhv = core.config.engine.fuel_lhv_j_per_g

    def _alloc(self, width: int) -> None:
        old = self.width
        new = {name: np.zeros((self.n, width)) for name in ("speed", "grade", "demand", "gear")}
        if old:
            for name, arr in new.items():
                arr[:, :old] = getattr(self, name)
                arr[:, old:] = getattr(self, name)[:, old - 1:old] if name in ("speed", "gear") else 0.0
        for name, arr in new.items():
            setattr(self, name, arr)
            setattr(self, f"_{name}_flat", arr.reshape(-1))
        self.width = width
        self.base = np.arange(self.n, dtype=np.int64) * width

    def load(self, rows: Sequence[int], episodes: Sequence[Episode], tables: Sequence[CycleTables],
             max_steps: int | None = None) -> None:
        """Start the given episodes in the given rows (state, tables, index) and compute their first envelope."""
        need = max(len(t.speed_mps) for t in tables) + self.pad
        if need > self.width:
            self._alloc(need)
        self.state = self.state.copy()  # states handed out earlier (infos, phys_state) stay untouched
        for i, ep, tab in zip(rows, episodes, tables):
            n = tab.speed_mps.size
            self.speed[i, :n] = tab.speed_mps
            self.speed[i, n:] = tab.speed_mps[-1]
            self.grade[i, :n] = tab.grade
            self.grade[i, n:] = 0.0
            self.demand[i, :n - 1] = tab.wheel_power_demand_kw
            self.demand[i, n - 1:] = 0.0
            self.gear[i, :n - 1] = tab.gear
            self.gear[i, n - 1:] = tab.gear[-1]
            self.state[i] = self.core.initial_state(ep.conditions, 1)[0]
            self.cond[i] = self.core.conditions_array(ep.conditions, 1)[0]
            self.soc_target[i] = ep.conditions.initial_soc
            self.k[i] = ep.start_s
            self.n_steps[i] = ep.cycle.n_steps
            self.end[i] = ep.cycle.n_steps if max_steps is None else min(ep.cycle.n_steps, ep.start_s + max_steps)
            self.cycles[i] = ep.cycle
            self.conditions[i] = ep.conditions
            self.last_out[i] = 0.0
        idx = np.asarray(rows, dtype=np.int64)
        self.avail[idx] = self._envelope(idx)

    def _envelope(self, rows: np.ndarray) -> np.ndarray:
        """Motor torque envelope of the coming step of ``rows`` (one core call with u = 0, nothing kept)."""
        j = self.base[rows] + self.k[rows]
        _, out = self.core.step(self.state[rows], np.zeros(rows.size), self._speed_flat[j], self._speed_flat[j + 1],
                                self._grade_flat[j], self.cond[rows])
        return out[:, C.MOTOR_AVAIL]

    def step(self, u: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
        """Advance every row with motor shares ``u`` (float64, already clipped to [-1, 1]).

        Returns the reward, its terms and the outputs [n, N_OUT] of the step; updates the state,
        ``k``, ``last_out`` and the envelope.
        """
        j = self.base + self.k
        state_out = np.empty((self.n, C.N_STATE))
        out = np.empty((self.n, C.N_OUT))
        C.step_kernel(self.core.gl, self.core.dl, self.core.en, self.core.mo, self.core.th, self.core.ba,
                      self.core.pt, self.state, u, self._speed_flat[j], self._speed_flat[j + 1], self._grade_flat[j],
                      self.cond, self.core.dt_s, state_out, out)
        terms = reward_terms(self.rp, out, state_out, self.soc_target, self.lhv, self.core.dt_s)
        self.state = state_out
        self.last_out = out
        self.avail = out[:, C.MOTOR_AVAIL].copy()
        self.k = self.k + 1
        return total_reward(terms), terms, out

    def observe(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Observations [n, dim] of all rows (or of ``rows``), float32, clipped to the declared bounds."""
        if rows is None:
            k, st, cond, soc_target, avail, n_steps = self.k, self.state, self.cond, self.soc_target, self.avail, \
                self.n_steps
            j = self.base + k
        else:
            k, st, cond, soc_target, avail, n_steps = self.k[rows], self.state[rows], self.cond[rows], \
                self.soc_target[rows], self.avail[rows], self.n_steps[rows]
            j = self.base[rows] + k
        # built transposed (one contiguous row per entry), returned C-ordered [n, dim]
        sp = self._speed_flat
        obs = np.empty((self.low.size, j.size), dtype=np.float32)
        v0 = sp[j]
        obs[OBS_SPEED] = v0
        obs[OBS_ACCEL] = (sp[j + 1] - v0) / self.core.dt_s
        obs[OBS_DEMAND] = self._demand_flat[j]
        st = st.T
        obs[OBS_SOC] = st[C.SOC]
        obs[OBS_SOC_TARGET] = soc_target
        obs[OBS_TEMP] = st[C.TEMP_C]
        obs[OBS_PWM] = st[C.HEAT_X]  # PWM = clip(x, 0, 1): the bounds clip below does it
        obs[OBS_HEAT_X] = st[C.HEAT_X]
        obs[OBS_CUTOFF] = st[C.CUTOFF]
        obs[OBS_AVAIL] = avail
        obs[OBS_GEAR] = self._gear_flat[j]
        obs[OBS_PROGRESS] = k / n_steps
        obs[OBS_AMBIENT] = cond[:, C.AMBIENT_C]
        obs[OBS_COOLANT] = cond[:, C.COOLANT_FACTOR]
        if self.offsets.size:
            obs[N_OBS_BASE:] = sp[self.offsets[:, None] + j[None, :]]
        np.maximum(obs, self.low32, out=obs)  # the clip to the declared bounds (np.clip is slower)
        np.minimum(obs, self.high32, out=obs)
        return np.ascontiguousarray(obs.T)


# --- the environment ------------------------------------------------------------------------------

class HevThermalEnv(gym.Env):
    r"""Energy management of a parallel hybrid city bus whose traction motor heats up and derates.

    ## Description

    A 15 t parallel hybrid city bus (the paper's vehicle, :func:`hev_thermal_env.paper_bus`) drives
    a speed cycle one second per step (backward-facing, ADVISOR-style). The agent is the
    energy-management strategy: each step it chooses the share of the coupler torque the traction
    motor carries; the diesel engine carries the rest. The water-cooled PMSM heats up (lumped
    thermal node, paper eqs 1-7), loses peak torque as its heat index (PWM, eqs 8-9) integrates
    sustained overload, loses efficiency as it warms and stops at 70 °C until it has cooled. Where
    the powertrain cannot deliver the demand, the step records a trace miss (missed wheel energy,
    speed deficit) and the reward prices it; the next step follows the cycle again. See
    ``DESIGN.md`` §3-4 and :mod:`hev_thermal_env.physics.core`.

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: u, the motor's share of the torque demanded at the coupler.
    Motor u·T_dem, engine (1 - u)·T_dem; u < 0 loads the engine more and charges the battery.
    The physics core clips the motor request to its envelope (peak torque, heat index, cutoff)
    and the battery's limits and lets the engine cover the rest up to its full load; what is
    still missing is a priced trace miss (the motor never tops up by itself). Braking is
    regenerative by rule (the action has no effect while braking or standing). Values outside
    [-1, 1] are clipped (``info["action_clipped"]``); NaN or inf, or a shape other than ``(1,)``,
    raise ``ValueError``.

    ## Observation Space

    ``Box`` of float32, ``14 + preview_s // preview_step_s`` entries, always inside the bounds
    (values are clipped to them). "Next step" is the step from ``cycle.speed_mps[k]`` to ``[k+1]``.

    | Num | Observation | Min | Max | Unit |
    |-----|-------------|-----|-----|------|
    | 0 | vehicle speed at the start of the next step (the cycle's; a miss is not carried over) | 0 | 60 | m/s |
    | 1 | acceleration the cycle demands over the next step | -10 | 10 | m/s² |
    | 2 | wheel power the cycle demands over the next step (road load, grade, inertia) | -2000 | 2000 | kW |
    | 3 | battery state of charge | 0 | 1 | - |
    | 4 | SOC target of the reward (the episode's initial SOC) | 0 | 1 | - |
    | 5 | motor temperature | -40 | 200 | °C |
    | 6 | heat index PWM (eq 9): 0 peak torque available, 1 continuous torque only | 0 | 1 | - |
    | 7 | heat-index integrator state x (eq 9), PWM = clip(x, 0, 1) | -1 | 1 | - |
    | 8 | motor cut off by its 70 °C protection (1) or not (0) | 0 | 1 | - |
    | 9 | motor torque envelope of the last step (at reset: of the first step), see below | 0 | peak torque | N·m |
    | 10 | gear of the next step (shift schedule on speed and load) | 1 | number of gears | - |
    | 11 | cycle progress k / n_steps | 0 | 1 | - |
    | 12 | ambient temperature | -40 | 60 | °C |
    | 13 | coolant heat-transfer multiplier: 1 on, 0 < f < 1 degraded, 0 off | 0 | 1 | - |
    | 14... | preview: cycle speed ``preview_step_s``, ``2·preview_step_s``, ... ``preview_s`` s ahead | 0 | 60 | m/s |

    Entry 9 is the motor's torque limit in the last step: the peak torque at that speed, derated
    by the heat index (eq 8), 0 while cut off; after reset, the limit for the first step. Its
    upper bound is the motor's peak torque (240 N·m for ``paper_bus``); that of entry 10 the number
    of gears (5). The preview is taken from the start of the next step and held at the cycle's last
    speed past its end; with the defaults (``preview_s=10``, ``preview_step_s=2``) it has 5 entries
    (+2 to +10 s) and the observation 19. :func:`observation_names` gives the names in order.

    ## Rewards

    :func:`hev_thermal_env.reward.reward_terms` with :class:`~hev_thermal_env.reward.RewardParams`,
    in grams of diesel equivalent: ``reward = reward_fuel + reward_miss + reward_soc + reward_overheat``:
    minus the fuel burned, minus the price of missed wheel energy (weight 2 by default), minus the
    fuel equivalent of the battery energy used and a quadratic deviation of the SOC from the target
    (the episode's initial SOC), minus an overheating penalty (quadratic above the 60 °C soft limit,
    20 per step while cut off, optionally per unit PWM). Each term is in ``info``.

    ## Starting State

    The scenario (``"paper"``: 20 °C ambient and motor, coolant on, SOC 0.65; ``"hot"``;
    ``"random"``: drawn every episode from ``self.np_random``) or ``conditions`` set the ambient
    temperature, the motor's starting temperature, the SOC and the coolant mode; reset options
    override them. The heat-index integrator starts at -PWM_initial(T_start) (eq 9). The episode
    starts at ``start_s`` into the cycle (0, or uniform with ``random_start``).

    ## Episode End

    ``truncated`` is True at the end of the cycle. ``terminated`` is always False: overheating,
    cutoff and trace misses are priced, not terminal.

    ## Arguments

    ```python
    gymnasium.make("HevThermal-v0", cycle="hwfet", scenario="paper", config=None, conditions=None,
                   reward=None, preview_s=10, preview_step_s=2, render_mode=None, thermal=None,
                   random_start=False)
    ```

    * ``cycle``: a built-in name (``hwfet``, ``udds``, ``us06``, ``wltc_3b``, ``beijing``), a CSV path,
      a :class:`~hev_thermal_env.cycles.Cycle`, ``"random_bus"`` (a fresh ``generate_bus_cycle`` per
      episode, seeded from ``self.np_random``), or a list of these (one drawn per episode).
    * ``scenario``: ``"paper"``, ``"hot"`` or ``"random"`` (:mod:`hev_thermal_env.scenarios`) or a
      :class:`~hev_thermal_env.scenarios.Scenario`.
    * ``config``: the :class:`~hev_thermal_env.physics.VehicleConfig` (default ``paper_bus()``).
    * ``conditions``: fixed :class:`~hev_thermal_env.physics.Conditions` for every episode (overrides
      the scenario).
    * ``reward``: :class:`~hev_thermal_env.reward.RewardParams` or a dict of its fields.
    * ``preview_s``, ``preview_step_s``: length and spacing of the speed preview (integers, seconds);
      ``preview_s=0`` removes it.
    * ``render_mode``: ``None``, ``"rgb_array"`` (an H×W×3 uint8 plot of speed, SOC, motor
      temperature, heat index and split so far) or ``"human"`` (the same in a matplotlib window,
      redrawn at every step and reset).
    * ``thermal``: if given, sets ``config.thermal.enabled`` (default None: the config's own setting,
      on for ``paper_bus()``); False is the paper's unmodified ADVISOR motor (no derating, no extra
      loss, no cutoff), the baseline of its tables.
    * ``random_start``: start each episode at a uniformly drawn second of the cycle (training).

    ``reset(seed=None, options=None)`` accepts the options ``cycle`` (as the argument, this
    episode only), ``ambient_temp_c``, ``initial_motor_temp_c``, ``initial_soc``, ``coolant``
    (``"on"``, ``"degraded"``, ``"off"``) and ``start_s`` (whole seconds into the cycle).

    ## Attributes for strategies (``env.unwrapped``)

    ``config``, ``core`` (:class:`~hev_thermal_env.physics.PhysicsCore`), ``conditions`` and
    ``cycle`` of the episode, ``k`` (index of the next step), ``phys_state`` ((1, N_STATE) state
    before the next step), ``cond`` ((1, N_COND)), ``reward_params``, ``soc_target``,
    ``last_out`` ((N_OUT,) outputs of the last step, zeros after reset) and :meth:`peek`, which
    evaluates candidate actions for the next step without changing the env.

    ## Version History

    * v0: initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}

    def __init__(self, cycle: Any = "hwfet", scenario: str | Scenario = "paper", config: VehicleConfig | None = None,
                 conditions: Conditions | None = None, reward: RewardParams | dict | None = None, preview_s: int = 10,
                 preview_step_s: int = 2, render_mode: str | None = None, thermal: bool | None = None,
                 random_start: bool = False):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self.config = resolve_config(config, thermal)
        self.core = C.PhysicsCore(self.config)
        self.sampler = EpisodeSampler(cycle, scenario, conditions, random_start)
        self.preview_s = int(preview_s)
        self.preview_step_s = int(preview_step_s)
        self.offsets = preview_offsets(preview_s, preview_step_s)
        low, high = observation_bounds(self.config, self.offsets.size)
        self.observation_space = spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.obs_names = observation_names(self.preview_s, self.preview_step_s)
        self._tables = TableCache(self.core, self.sampler.cycles.fixed_cycles())
        self._rows = EpisodeRows(self.core, 1, self.offsets, low, high, resolve_reward(reward))
        self._u = np.zeros(1)
        self.cycle: Cycle | None = None
        self.conditions: Conditions | None = None
        self._history: dict[str, list] | None = None
        self._plot = None

    # -- contract attributes ---------------------------------------------------------------------

    @property
    def k(self) -> int:
        """Index of the next step (from ``cycle.speed_mps[k]`` to ``[k+1]``)."""
        return int(self._rows.k[0])

    @property
    def phys_state(self) -> np.ndarray:
        """State before the next step, shape (1, N_STATE)."""
        return self._rows.state

    @property
    def cond(self) -> np.ndarray:
        """Conditions array of the episode, shape (1, N_COND)."""
        return self._rows.cond

    @property
    def soc_target(self) -> float:
        """SOC target of the reward's deviation term: the episode's initial SOC."""
        return float(self._rows.soc_target[0])

    @property
    def reward_params(self) -> RewardParams:
        return self._rows.rp

    @reward_params.setter
    def reward_params(self, value: RewardParams | dict) -> None:
        self._rows.rp = resolve_reward(value)

    @property
    def last_out(self) -> np.ndarray:
        """Outputs (N_OUT,) of the last step (zeros after reset); columns in ``physics.core.OUT_NAMES``."""
        return self._rows.last_out[0]

    # -- gymnasium API ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        ep = self.sampler.sample(self.np_random, options)
        tab = self._tables.get(ep)
        self._rows.last_out = np.zeros((1, C.N_OUT))  # a fresh array: references to the last one stay valid
        self._rows.load([0], [ep], [tab])
        self.cycle = ep.cycle
        self.conditions = ep.conditions
        obs = self._rows.observe()[0]
        info = reset_info_dict(self._rows, 0, ep)
        if self.render_mode is not None:
            self._history = {name: [] for name in ("time_s", "cycle_speed_mps", "speed_mps", "soc", "motor_temp_c",
                                                    "heat_index", "action")}
            self._record_reset(ep)
            if self.render_mode == "human":
                self.render()
        return obs, info

    def step(self, action):
        u, clipped = check_action(action)
        rows = self._rows
        if self.cycle is None:
            raise RuntimeError("call reset() before step()")
        if rows.k[0] >= rows.end[0]:
            raise RuntimeError("the episode has ended (truncated at the end of the cycle); call reset()")
        self._u[0] = u
        reward, terms, out = rows.step(self._u)
        k = int(rows.k[0])
        truncated = k >= rows.end[0]
        obs = rows.observe()[0]
        info = step_info_dict(out[0], rows.state[0], terms, rows.speed[0, k], float(rows.k[0]), u, clipped)
        if self._history is not None:
            self._record_step(info)
            if self.render_mode == "human":
                self.render()
        return obs, float(reward[0]), False, bool(truncated), info

    def peek(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate candidate actions for the next step from the current state, without changing the env.

        ``actions``: n motor shares (any shape with n elements; clipped to [-1, 1] by the core).
        Returns ``(state_out [n, N_STATE], out [n, N_OUT])`` from one batched call of the physics core.
        """
        a = np.array(actions, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(a)):
            raise ValueError("peek: actions contain NaN or inf")
        rows = self._rows
        if self.cycle is None or rows.k[0] >= rows.end[0]:
            raise RuntimeError("peek: no next step (call reset() first)")
        n = a.size
        k = int(rows.k[0])
        return self.core.step(np.repeat(rows.state, n, axis=0), a, np.full(n, rows.speed[0, k]),
                              np.full(n, rows.speed[0, k + 1]), np.full(n, rows.grade[0, k]),
                              np.repeat(rows.cond, n, axis=0))

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        from .render import EpisodePlot

        if self._plot is None:
            self._plot = EpisodePlot(human=self.render_mode == "human", fps=self.metadata["render_fps"])
        self._plot.draw(self._history or {}, self.cycle, self.config)
        return self._plot.to_rgb() if self.render_mode == "rgb_array" else None

    def close(self):
        if self._plot is not None:
            self._plot.close()
            self._plot = None

    # -- rendering history (only with a render_mode) ---------------------------------------------

    def _record_reset(self, ep: Episode) -> None:
        h = self._history
        st = self._rows.state[0]
        h["time_s"].append(float(ep.start_s))
        h["cycle_speed_mps"].append(float(ep.cycle.speed_mps[ep.start_s]))
        h["speed_mps"].append(float(ep.cycle.speed_mps[ep.start_s]))
        h["soc"].append(float(st[C.SOC]))
        h["motor_temp_c"].append(float(st[C.TEMP_C]))
        h["heat_index"].append(min(max(float(st[C.HEAT_X]), 0.0), 1.0))
        h["action"].append(math.nan)

    def _record_step(self, info: dict) -> None:
        for name, values in self._history.items():
            values.append(info[name])


class TableCache:
    """Cycle tables of the env's fixed cycles, computed once; other cycles (random, from options) fresh."""

    def __init__(self, core: C.PhysicsCore, fixed: Sequence[Cycle]):
        self.core = core
        self._fixed = {id(c): c for c in fixed}
        self._cache: dict[int, CycleTables] = {}

    def get(self, ep: Episode) -> CycleTables:
        key = id(ep.cycle)
        tab = self._cache.get(key)
        if tab is not None:
            return tab
        st = self.core.initial_state(ep.conditions, 1)[0]
        tab = CycleTables(self.core, ep.cycle, st, self.core.conditions_array(ep.conditions, 1)[0])
        if self._fixed.get(key) is ep.cycle:
            self._cache[key] = tab
        return tab


def resolve_config(config: VehicleConfig | None, thermal: bool | None) -> VehicleConfig:
    """The vehicle: ``config`` (default ``paper_bus()``), its thermal model switched by ``thermal`` if given."""
    if config is None:
        config = paper_bus()
    if not isinstance(config, VehicleConfig):
        raise TypeError(f"config: expected VehicleConfig or None, got {type(config).__name__}")
    return config if thermal is None else config.with_thermal(bool(thermal))


def resolve_reward(reward: RewardParams | dict | None) -> RewardParams:
    if reward is None:
        return RewardParams()
    if isinstance(reward, RewardParams):
        return reward
    if isinstance(reward, dict):
        return RewardParams.from_dict(reward, where="reward")
    raise TypeError(f"reward: expected RewardParams, a dict or None, got {type(reward).__name__}")


def check_action(action: Any) -> tuple[float, bool]:
    """The motor share of a single-env action (clipped to [-1, 1]) and whether it was clipped."""
    if type(action) is not np.ndarray:
        try:
            action = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"action must be an array of shape (1,) (the motor's share u), got {action!r}") from None
    if action.shape != (1,):
        raise ValueError(f"action must have shape (1,) (the motor's share u), got shape {action.shape}")
    u = float(action[0])
    if not math.isfinite(u):
        raise ValueError(f"action must be finite, got {u}")
    uc = -1.0 if u < -1.0 else (1.0 if u > 1.0 else u)
    return uc, uc != u


def step_info_dict(out: np.ndarray, state: np.ndarray, terms: dict[str, np.ndarray], cycle_speed: float,
                   time_s: float, u: float, clipped: bool) -> dict[str, Any]:
    """The ``info`` of one step of the single env (same values as the vector env's info arrays)."""
    o = out.tolist()
    info = {
        "fuel_g": o[C.FUEL_G], "soc": float(state[C.SOC]), "motor_temp_c": float(state[C.TEMP_C]),
        "heat_index": o[C.HEAT_INDEX], "motor_torque_nm": o[C.MOTOR_TORQUE],
        "motor_speed_rpm": o[C.MOTOR_SPEED] * RPM_PER_RADPS, "motor_heat_w": o[C.MOTOR_HEAT],
        "engine_torque_nm": o[C.ENGINE_TORQUE], "engine_speed_rpm": o[C.ENGINE_SPEED] * RPM_PER_RADPS,
        "engine_on": o[C.ENGINE_ON] != 0.0, "gear": int(o[C.GEAR]), "speed_mps": o[C.SPEED],
        "trace_miss_mps": o[C.TRACE_MISS], "motor_cutoff": bool(state[C.CUTOFF] != 0.0),
        "coolant_on": o[C.COOLANT_ON] != 0.0,
    }
    for key in _REWARD_KEYS:
        info[key] = float(terms[key][0])
    info.update(
        missed_wheel_energy_j=o[C.MISSED_J], battery_chem_power_w=o[C.BATT_CHEM], battery_power_w=o[C.BATT_POWER],
        motor_torque_avail_nm=o[C.MOTOR_AVAIL], cycle_speed_mps=float(cycle_speed), time_s=time_s, action=u,
        action_clipped=clipped, motor_torque_clipped=o[C.MOTOR_CLIPPED] != 0.0)
    return info


def step_info_arrays(out: np.ndarray, state: np.ndarray, terms: dict[str, np.ndarray], cycle_speed: np.ndarray,
                     time_s: np.ndarray, u: np.ndarray, clipped: np.ndarray) -> dict[str, np.ndarray]:
    """The step infos of a batch as one array per key (one column slice per key)."""
    info = {name: out[:, col] for name, col in _INFO_OUT_COLUMNS}
    for name, col in _INFO_RPM_COLUMNS:
        info[name] = out[:, col] * RPM_PER_RADPS
    for name, col in _INFO_BOOL_COLUMNS:
        info[name] = out[:, col] != 0.0
    info["gear"] = out[:, C.GEAR].astype(np.int64)
    info["soc"] = state[:, C.SOC]
    info["motor_temp_c"] = state[:, C.TEMP_C]
    info["motor_cutoff"] = state[:, C.CUTOFF] != 0.0
    info.update(terms)
    info["cycle_speed_mps"] = cycle_speed
    info["time_s"] = time_s
    info["action"] = u
    info["action_clipped"] = clipped
    return {key: info[key] for key in INFO_KEYS}


def reset_info_dict(rows: EpisodeRows, i: int, ep: Episode) -> dict[str, Any]:
    st = rows.state[i]
    return {
        "cycle_name": ep.cycle.name, "start_s": ep.start_s, "time_s": float(ep.start_s), "soc": float(st[C.SOC]),
        "soc_target": float(rows.soc_target[i]), "motor_temp_c": float(st[C.TEMP_C]),
        "heat_index": min(max(float(st[C.HEAT_X]), 0.0), 1.0), "motor_cutoff": bool(st[C.CUTOFF] != 0.0),
        "ambient_temp_c": float(ep.conditions.ambient_temp_c), "coolant": ep.conditions.coolant,
    }
