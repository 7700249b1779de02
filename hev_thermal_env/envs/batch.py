"""The batch engine: a batch of vehicles, each on its own cycle, stepped together; the step of every env.

:class:`EpisodeRows` holds per row the cycle tables (padded to a common width), the step index, the state, the
conditions and the SOC target. :meth:`EpisodeRows.step` is one call of :func:`advance_kernel` (physics, reward and
observation, :func:`observe_kernel`, fused): one dispatch per step, so the single env (a batch of one) steps as cheaply
as a classic-control env; the vector env is a batch of n. Nothing that plans (DP, the thermal optimum) imports it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from ..cycles import Cycle
from ..physics import core as physics_core
from ..physics.config import Conditions, VehicleConfig, check_physics, paper_bus
from ..physics.jit import jit
from . import spaces as env_spaces
from .episodes import CycleTables, Episode, EpisodeSampler, TableCache
from .reward import REWARD_TERMS, RewardParams, band_center, descent_soc, reward_kernel


@jit
def observe_kernel(w, rows, k, state, cond, soc_target, avail, n_steps, speed, demand, gear, descent, offsets, dt_s,
                   low, high, obs):
    """Observations of ``rows`` into ``obs`` [len(rows), dim] (float32, clipped to [low, high]), in the order of
    :func:`~hev_thermal_env.envs.spaces.observation_names`; the band's center from ``descent`` and the weights ``w``."""
    n_base = env_spaces.N_OBS_BASE
    for i in range(rows.shape[0]):
        r = rows[i]
        j = k[r]
        v0 = speed[r, j]
        obs[i, env_spaces.OBS_SPEED] = v0
        obs[i, env_spaces.OBS_ACCEL] = (speed[r, j + 1] - v0) / dt_s
        obs[i, env_spaces.OBS_DEMAND] = demand[r, j]
        obs[i, env_spaces.OBS_SOC] = state[r, physics_core.SOC]
        center = band_center(w, soc_target[r], descent[r, j])
        obs[i, env_spaces.OBS_SOC_TARGET] = center
        obs[i, env_spaces.OBS_SOC_DEVIATION] = state[r, physics_core.SOC] - center
        obs[i, env_spaces.OBS_TEMP] = state[r, physics_core.TEMP_C]
        obs[i, env_spaces.OBS_WINDING] = state[r, physics_core.WINDING_C]
        obs[i, env_spaces.OBS_PWM] = state[r, physics_core.HEAT_X]  # PWM = clip(x, 0, 1): the bounds below clip it
        obs[i, env_spaces.OBS_HEAT_X] = state[r, physics_core.HEAT_X]
        # either protection stops the motor
        obs[i, env_spaces.OBS_CUTOFF] = max(state[r, physics_core.CUTOFF], state[r, physics_core.WINDING_TRIP])
        obs[i, env_spaces.OBS_AVAIL] = avail[r]
        obs[i, env_spaces.OBS_GEAR] = gear[r, j]
        obs[i, env_spaces.OBS_PROGRESS] = j / n_steps[r]
        obs[i, env_spaces.OBS_AMBIENT] = cond[r, physics_core.AMBIENT_C]
        obs[i, env_spaces.OBS_COOLANT] = cond[r, physics_core.COOLANT_FACTOR]
        for p in range(offsets.shape[0]):
            obs[i, n_base + p] = speed[r, j + offsets[p]]
        for c in range(obs.shape[1]):
            x = obs[i, c]
            if x < low[c]:
                obs[i, c] = low[c]
            elif x > high[c]:
                obs[i, c] = high[c]


@jit
def advance_kernel(gl, dl, en, mo, th, ba, pt, dt_s, w, u, tables, k, n_steps, state, cond, soc_target, offsets,
                   low, high, all_rows, state_out, out, terms, total, avail, obs):
    """One step of every row: physics, reward, step index, motor envelope and the next observation.

    ``tables`` [5, n, width] holds speed, grade, demanded wheel power (kW), gear and the SOC the descent to the route's
    end can return (:func:`~hev_thermal_env.envs.reward.descent_soc`) per row and step; the band's center before and
    after the step follows from it and ``soc_target``. Writes ``state_out``, ``out``, ``terms``/``total`` (the reward),
    ``avail`` (the motor envelope of the step, the next observation's entry) and ``obs``; increments ``k``.
    """
    n = u.shape[0]
    v0, v1, g, c0, c1 = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for r in range(n):
        v0[r] = tables[0, r, k[r]]
        v1[r] = tables[0, r, k[r] + 1]
        g[r] = tables[1, r, k[r]]
        c0[r] = band_center(w, soc_target[r], tables[4, r, k[r]])
        c1[r] = band_center(w, soc_target[r], tables[4, r, k[r] + 1])
    physics_core.step_kernel(gl, dl, en, mo, th, ba, pt, state, u, v0, v1, g, cond, dt_s, state_out, out)
    reward_kernel(w, out, state, state_out, c0, c1, dt_s, terms, total)
    for r in range(n):
        k[r] += 1
        avail[r] = out[r, physics_core.MOTOR_AVAIL]
    observe_kernel(w, all_rows, k, state_out, cond, soc_target, avail, n_steps, tables[0], tables[2], tables[3],
                   tables[4], offsets, dt_s, low, high, obs)


class EpisodeRows:
    """Per-row episode tables of a batch of vehicles, each on its own cycle; the step of both envs."""

    def __init__(self, core: physics_core.PhysicsCore, n_rows: int, offsets: np.ndarray, low: np.ndarray,
                 high: np.ndarray, reward_params: RewardParams):
        self.core, self.n = core, n_rows
        self.offsets = np.ascontiguousarray(offsets, dtype=np.int64)
        self.low, self.high = low.astype(np.float32), high.astype(np.float32)  # the observation's bounds
        self.lhv = core.config.engine.fuel_lhv_j_per_g
        self.reward_params = reward_params
        self.pad = int(self.offsets.max()) + 2 if self.offsets.size else 2
        self.tables = np.zeros((5, n_rows, 2))
        self.all_rows, self.k = np.arange(n_rows, dtype=np.int64), np.zeros(n_rows, dtype=np.int64)
        self.end, self.n_steps = np.ones(n_rows, dtype=np.int64), np.ones(n_rows, dtype=np.int64)
        self.state, self.cond = np.zeros((n_rows, physics_core.N_STATE)), np.zeros((n_rows, physics_core.N_COND))
        self.soc_target, self.avail = np.zeros(n_rows), np.zeros(n_rows)
        self.last_out = np.zeros((n_rows, physics_core.N_OUT))
        self.cycles: list[Cycle | None] = [None] * n_rows
        self.conditions: list[Conditions | None] = [None] * n_rows

    @property
    def reward_params(self) -> RewardParams:
        return self._reward_params

    @reward_params.setter
    def reward_params(self, value: RewardParams) -> None:
        self._reward_params = value
        self._weights = value.weights(self.lhv)

    speed = property(lambda self: self.tables[0], doc="Cycle speed [n, width] of every row (held at its last value).")
    grade = property(lambda self: self.tables[1], doc="Road grade [n, width] of every row (0 past the cycle's end).")

    @property
    def band_center(self) -> np.ndarray:
        """The SOC band's center [n, width] of every row at every instant (held at the target past the end)."""
        return band_center(self._weights, self.soc_target[:, None], self.tables[4])

    def load(self, rows: Sequence[int], episodes: Sequence[Episode], tables: Sequence[CycleTables],
             max_steps: int | None = None) -> None:
        """Start the given episodes in the given rows (state, tables, index) and compute their first envelope."""
        need = max(len(t.speed_mps) for t in tables) + self.pad
        if need > self.tables.shape[2]:  # the last column holds every row's value past its end (speed and gear held)
            self.tables = np.pad(self.tables, ((0, 0), (0, 0), (0, need - self.tables.shape[2])), mode="edge")
        self.state = self.state.copy()  # states handed out earlier (infos, phys_state) stay untouched
        speed, grade, demand, gear, descent = self.tables
        gl, ba = self.core.config.glider, self.core.config.battery
        j_per_soc = ba.nominal_energy_kwh * 3.6e6
        for i, ep, tab in zip(rows, episodes, tables):
            n = tab.speed_mps.size
            speed[i, :n], speed[i, n:] = tab.speed_mps, tab.speed_mps[-1]
            grade[i, :n], grade[i, n:] = tab.grade, 0.0
            demand[i, :n - 1], demand[i, n - 1:] = tab.wheel_power_demand_kw, 0.0
            gear[i, :n - 1], gear[i, n - 1:] = tab.gear, tab.gear[-1]
            self.state[i] = self.core.initial_state(ep.conditions, 1)[0]
            self.cond[i] = self.core.conditions_array(ep.conditions, 1)[0]
            self.soc_target[i] = ep.soc_target
            descent[i, :n] = descent_soc(tab.climb_m, gl.mass_kg + ep.conditions.payload_kg, gl.gravity_mps2,
                                         j_per_soc)
            descent[i, n:] = 0.0
            self.k[i], self.n_steps[i] = ep.start_s, ep.cycle.n_steps
            self.end[i] = ep.cycle.n_steps if max_steps is None else min(ep.cycle.n_steps, ep.start_s + max_steps)
            self.cycles[i], self.conditions[i] = ep.cycle, ep.conditions
            self.last_out[i] = 0.0
        idx = np.asarray(rows, dtype=np.int64)
        self.avail[idx] = self._envelope(idx)

    def _envelope(self, rows: np.ndarray) -> np.ndarray:
        """Motor torque envelope of the coming step of ``rows`` (one core call with u = 0, nothing kept)."""
        k = self.k[rows]
        _, out = self.core.step(self.state[rows], 0.0, self.speed[rows, k], self.speed[rows, k + 1],
                                self.grade[rows, k], self.cond[rows])
        return out[:, physics_core.MOTOR_AVAIL]

    def step(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Advance every row with motor shares ``u`` (float64 [n], already clipped to [-1, 1]).

        Returns (reward [n], terms [n, 4] in ``REWARD_TERMS`` order, outputs [n, N_OUT], next observations [n, dim]);
        updates the state, ``k``, ``last_out`` and the envelope.
        """
        n, core = self.n, self.core
        state_out, out = np.empty((n, physics_core.N_STATE)), np.empty((n, physics_core.N_OUT))
        terms, total = np.empty((n, len(REWARD_TERMS))), np.empty(n)
        obs = np.empty((n, self.low.size), dtype=np.float32)
        advance_kernel(core.gl, core.dl, core.en, core.mo, core.th, core.ba, core.pt, core.dt_s, self._weights, u,
                       self.tables, self.k, self.n_steps, self.state, self.cond, self.soc_target, self.offsets,
                       self.low, self.high, self.all_rows, state_out, out, terms, total, self.avail, obs)
        self.state, self.last_out = state_out, out
        return total, terms, out, obs

    def observe(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Observations [n, dim] of all rows (or of ``rows``), float32, clipped to the declared bounds."""
        idx = self.all_rows if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
        obs = np.empty((idx.size, self.low.size), dtype=np.float32)
        observe_kernel(self._weights, idx, self.k, self.state, self.cond, self.soc_target, self.avail, self.n_steps,
                       self.tables[0], self.tables[2], self.tables[3], self.tables[4], self.offsets, self.core.dt_s,
                       self.low, self.high, obs)
        return obs


class EnvParts:
    """What the single and the vector env share: the vehicle, the episode sampler and the batch engine
    (:meth:`_build`), and the attributes read through the engine."""

    def _build(self, n_rows: int, cycle: Any, scenario: Any, config: VehicleConfig | None, conditions: Any, reward: Any,
               preview_s: int, preview_step_s: int, thermal: bool | None, random_start: bool,
               info_keys: Any, soc_offset: float = 0.0, physics: int = 2) -> tuple[spaces.Box, spaces.Box]:
        """Build the parts from the env's arguments; returns one env's observation and action spaces."""
        self.info_keys = env_spaces.check_info_keys(info_keys)
        self.physics = check_physics(physics)
        if config is None:
            config = paper_bus(physics=self.physics)
        if not isinstance(config, VehicleConfig):
            raise TypeError(f"config: expected VehicleConfig or None, got {type(config).__name__}")
        self.config = config if thermal is None else config.with_thermal(bool(thermal))
        self.core = physics_core.PhysicsCore(self.config)
        # the dt_s of safety_cost: 0 with the thermal model off (the heat index is still integrated then, but nothing
        # derates or stops)
        self._cost_step_s = float(self.core.dt_s) if self.config.thermal.enabled else 0.0
        battery = self.config.battery
        self.sampler = EpisodeSampler(cycle, scenario, conditions, random_start, soc_offset,
                                      (battery.soc_min, battery.soc_max))
        offsets = env_spaces.preview_offsets(preview_s, preview_step_s)
        self.preview_s, self.preview_step_s = int(preview_s), int(preview_step_s)
        self.obs_names = env_spaces.observation_names(self.preview_s, self.preview_step_s)
        low, high = env_spaces.observation_bounds(self.config, offsets.size)
        self._tables = TableCache(self.core, [c for c in self.sampler.cycles.items if isinstance(c, Cycle)])
        self._rows = EpisodeRows(self.core, n_rows, offsets, low, high, RewardParams.of(reward, self.physics))
        return (spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32),
                spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32))

    def _start(self, idx: Sequence[int], rngs: Sequence[np.random.Generator], options: Sequence[dict | None],
               max_steps: int | None = None) -> list[dict[str, Any]]:
        """Draw an episode for each row of ``idx`` from its generator and reset options, start them; their reset
        infos."""
        episodes = [self.sampler.sample(rng, opt) for rng, opt in zip(rngs, options)]
        self._rows.load(idx, episodes, [self._tables.get(ep) for ep in episodes], max_steps)
        return [env_spaces.reset_info_dict(self._rows, i, ep) for i, ep in zip(idx, episodes)]

    @property
    def reward_params(self) -> RewardParams:
        return self._rows.reward_params

    @reward_params.setter
    def reward_params(self, value: RewardParams | dict) -> None:
        self._rows.reward_params = RewardParams.of(value)

    @property
    def phys_state(self) -> np.ndarray:
        """State before the next step, [n, N_STATE] (n = 1 for the single env)."""
        return self._rows.state

    @property
    def cond(self) -> np.ndarray:
        """Conditions array of the episodes, [n, N_COND]."""
        return self._rows.cond

