"""``HevThermal-v2`` (and v1), a thin MDP layer in the classic-control style; its spec is the class docstring.

``step`` is dynamics, reward and termination in one call of the batch engine (:mod:`.batch`, a batch of one); episodes
(cycle, conditions, start) are drawn by :mod:`.episodes` from the scenario.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from ..physics import core
from ..physics.config import Conditions, VehicleConfig
from ..scenarios import Scenario
from . import spaces
from .batch import EnvParts
from .render import EpisodePlot
from .reward import RewardParams


class HevThermalEnv(EnvParts, gym.Env):
    r"""Energy management of a parallel hybrid city bus whose traction motor heats up and derates.

    ## Description

    A 15 t parallel hybrid city bus (the paper's vehicle, :func:`hev_thermal_env.paper_bus`) drives a speed cycle one
    second per step (backward-facing, ADVISOR-style). The agent is the energy-management strategy: each step it chooses
    the share of the coupler torque the traction motor carries (and, while braking, its share of the regeneration);
    the diesel engine carries the rest. The water-cooled PMSM heats up (by default a lumped thermal network of winding,
    stator/housing and a pumped coolant loop with thermostat valve and radiator, docs/thermal_model.md;
    ``paper_bus("paper_eqs")`` is the paper's one-node eqs 1-7), loses peak torque as its heat index (PWM, eqs 8-9)
    integrates sustained overload, loses efficiency as it warms and stops at 70 °C (the stator/housing node, the
    paper's motor temperature) or at a 165 °C winding until it has cooled. Where the powertrain cannot deliver
    the demand, the step records a priced trace miss; the next step follows the cycle again
    (:mod:`hev_thermal_env.physics.core`).

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: u, the motor's share of the torque demanded at the coupler: motor u·T_dem, engine
    (1 - u)·T_dem; u < 0 loads the engine more and charges the battery. In traction, u ≥ 0.9 stops the engine and the
    motor carries the demand alone, as at u = 1 (``PowertrainParams.engine_min_share``; v1: only u = 1). The physics
    core clips the motor request to its envelope (peak torque, heat index, cutoff) and the battery's limits and the
    engine covers the rest up to its full load (the motor never tops up by itself); a charge (u < 0) that the engine
    at full load cannot carry on top of the demand is cut down, to none at the least, before the trace is missed
    (``charge_yields_to_demand``; v1: the bus misses its trace). While braking, u > 0 is the motor's share of the
    available regeneration (friction brakes take the rest) and u ≤ 0 brakes by friction alone, so u = 0 throughout
    leaves the motor unused (``engine_only``); standing, the action has no effect. Values outside [-1, 1] are clipped
    (``info["motor_share_clipped"]``; ``info["motor_share"]`` is the share applied); NaN or inf, or a shape other than
    ``(1,)``, raise ``ValueError``.

    ## Observation Space

    ``Box`` of float32, ``16 + preview_s // preview_step_s`` entries, always inside the bounds (values are clipped to
    them). "Next step" is the step from ``cycle.speed_mps[k]`` to ``[k+1]``.

    | Num | Observation | Min | Max | Unit |
    |-----|-------------|-----|-----|------|
    | 0 | vehicle speed at the start of the next step (the cycle's; a miss is not carried over) | 0 | 60 | m/s |
    | 1 | acceleration the cycle demands over the next step | -10 | 10 | m/s² |
    | 2 | wheel power the cycle demands over the next step (road load, grade, inertia) | -2000 | 2000 | kW |
    | 3 | battery state of charge | 0 | 1 | - |
    | 4 | center c(t) of the reward's SOC band (the episode's initial SOC on a flat route; see Rewards) | 0 | 1 | - |
    | 5 | SOC minus the band's center: the settlement is zero within ±0.01 of it | -1 | 1 | - |
    | 6 | motor temperature (the stator/housing node, the paper's lumped motor temperature) | -40 | 200 | °C |
    | 7 | winding temperature (hot-spot node; its protection trips at 165 °C) | -40 | 250 | °C |
    | 8 | heat index PWM (eq 9): 0 peak torque available, 1 continuous torque only | 0 | 1 | - |
    | 9 | heat-index integrator state x (eq 9), PWM = clip(x, 0, 1) | -1 | 1 | - |
    | 10 | motor stopped by a protection (70 °C motor or 165 °C winding) (1) or not (0) | 0 | 1 | - |
    | 11 | motor torque envelope of the last step (at reset: of the first step), see below | 0 | peak torque | N·m |
    | 12 | gear of the next step (shift schedule on speed and load), 1 or more | 0 | number of gears | - |
    | 13 | cycle progress k / n_steps | 0 | 1 | - |
    | 14 | ambient temperature | -40 | 60 | °C |
    | 15 | coolant multiplier (the pump's flow): 1 on, 0 < f < 1 degraded, 0 off | 0 | 1 | - |
    | 16... | preview: cycle speed ``preview_step_s``, ``2·preview_step_s``, ... ``preview_s`` s ahead | 0 | 60 | m/s |

    Entry 11 is the motor's torque limit in the last step (after reset: in the first): the peak torque at that speed,
    derated by the heat index (eq 8), 0 while cut off; its upper bound is the motor's peak torque (240 N·m for
    ``paper_bus``), that of entry 12 the number of gears (5), its lower bound 0 so that an all-zero observation lies
    inside the space (torchrl fills a batch's final observation with zeros). The preview starts at the next step and
    holds the cycle's last speed past its end; with the defaults it has 5 entries (+2 to +10 s), the observation 21.
    :func:`observation_names` gives the names in order.

    ## Rewards

    In grams of diesel equivalent (negative = cost), one compiled function for the env, the vector env, DP and ECMS
    (:func:`~hev_thermal_env.envs.reward.reward_kernel`), with the weights and prices of
    :class:`~hev_thermal_env.envs.reward.RewardParams` (every one a field):
    ``reward = reward_fuel + reward_miss + reward_soc + reward_overheat``, each term in ``info``::

        reward_fuel     = −fuel_weight · fuel_g
        reward_miss     = −miss_weight · (price of the missed wheel energy)
        reward_soc      = −soc_energy_weight · (fuel equivalent of the battery's chemical energy this step)
                          + Φ(SOC after the step, c after) − Φ(SOC before, c before)        (band settlement)
                          − soc_deviation_weight · ((SOC − c) / soc_deviation_scale)²
        reward_overheat = −overheat_temp_weight · max(T − overheat_soft_limit_c, 0)² − cutoff_weight · [stopped]
                          − derate_weight · clip(x − derate_from_x, 0, 1 − derate_from_x)
                          − motor_life_cost_g · dt / (insulation_life_h · 2^((insulation_class_temp_c − T_w) / 10 K))
        Φ(SOC, c)       = −soc_band_weight · max(|SOC − c| − soc_band, 0)

    The prices (:class:`~hev_thermal_env.prices.Prices`) are those of the corrected fuel
    (:mod:`hev_thermal_env.metrics`): with the default weights an episode's fuel, miss and battery terms add up to
    minus its corrected fuel, so DP and ECMS, which minimise the same terms, optimise the metric they are judged by.

    Why the band settlement: at the battery's average price alone, ending with more charge pays (the engine's marginal
    efficiency under load is better; docs/metrics.md). The settlement, the potential difference of the dead-zone hinge
    Φ, adds up over an episode to −10,000 g per unit SOC that the final SOC lies beyond the band (±``soc_band`` = 0.01
    around c), paid as the SOC leaves the band and refunded as it returns: about the battery price of a unit of
    ``paper_bus``'s SOC (≈9,450 g), 9 times the most that ending beyond the band earns (≈1,100 g). The optimum is
    charge-sustaining, a run that starts and ends inside the band returns exactly minus its corrected fuel and the
    overheat terms, and a step's settlement stays within ≈10 g (a larger pack needs a larger ``soc_band_weight``).

    The band's center c(t) is the episode's initial SOC on a flat route and at the route's end; on high ground it sits
    lower by the charge the remaining descent will return (:func:`~hev_thermal_env.envs.reward.band_center`)::

        c(t) = SOC_start − descent_recovery · m · g · (h(t) − h_end) / E_per_SOC

    with ``descent_recovery`` = 0.6 (≈ driveline 0.93 × charge path 0.90 × the ≈0.75 of the potential energy that
    rolling and air resistance leave on a city descent): charge spent on a climb that the descent refills costs
    nothing meanwhile. The episode still pays exactly for its final SOC, plus a constant of its start (zero when the
    route starts as high as it ends or inside the band).

    ## Info

    ``reset`` and ``step`` return the keys of :data:`~hev_thermal_env.envs.spaces.INFO_KEYS` in order (the contract
    first, then extras such as ``motor_share``, the share u applied, and the episode's
    :data:`~hev_thermal_env.envs.spaces.EPISODE_INFO_KEYS`), or those chosen by ``info_keys``. Every value is a numpy
    scalar of one type per key (:data:`~hev_thermal_env.envs.spaces.INFO_DTYPES`), so that readers that store infos
    with a fixed dtype (torchrl, Minari's ``DataCollector(record_infos=True)``, gymnasium's vector wrappers) take them
    unchanged. A reset's info holds the starting state (:data:`~hev_thermal_env.envs.spaces.STATE_INFO_KEYS`) and zero
    or False for every quantity of a step. The cycle and the coolant mode are codes: ``cycle_id``
    (:func:`~hev_thermal_env.envs.spaces.cycle_name`) and ``coolant_code``
    (:func:`~hev_thermal_env.envs.spaces.coolant_mode`).

    ## Cost

    ``info["cost"]``, the step's **safety cost** (Safety-Gymnasium's convention: a per-step cost for constrained RL
    beside the reward, which does not contain it)::

        cost = dt · max(PWM, [stopped])        (in seconds, ≥ 0, at most 1 per 1-s step)

    PWM (eq 9) is the heat index after the step, the share of the motor's overload reserve, peak minus continuous
    torque (eq 8), that heat has taken away; ``[stopped]`` is 1 while either protection (70 °C motor, 165 °C winding)
    holds the motor at zero torque: an episode's safety cost reads as seconds of lost motor capability, 0 throughout
    with ``thermal=False`` (:func:`~hev_thermal_env.envs.spaces.safety_cost`; why this measure: docs/tasks.md).

    ## Starting State

    The scenario (``"paper"``: 20 °C ambient and motor, coolant on, SOC 0.65; the randomised ones draw every episode
    from ``self.np_random``) or ``conditions`` set the ambient and starting temperatures, the SOC, the coolant mode and
    the payload; reset options override them. The heat-index integrator starts at -PWM_initial(T_start) (eq 9). The
    episode starts at ``start_s`` into the cycle (0, or uniform with ``random_start``).

    ## Episode End

    ``truncated`` is True at the end of the cycle. ``terminated`` is always False: overheating, cutoff and trace misses
    are priced, not terminal.

    ## Arguments

    ```python
    gymnasium.make("HevThermal-v2", cycle="hwfet", scenario="paper", config=None, conditions=None,
                   reward=None, preview_s=10, preview_step_s=2, render_mode=None, thermal=None,
                   random_start=False, info_keys="all", soc_offset=0.0, physics=2)
    ```

    * ``cycle``: a built-in name (:func:`~hev_thermal_env.cycles.list_cycles`), a CSV path, a
      :class:`~hev_thermal_env.cycles.Cycle`, a generated cycle's name (``bus_long:7``, ``validation_bus:3``) or set
      (``validation_bus``), a cycle family (:func:`~hev_thermal_env.cycles.list_families`: a fresh cycle of the family
      per episode, seeded from ``self.np_random``), or a list of these (one drawn per episode).
    * ``scenario``: a name of :func:`~hev_thermal_env.scenarios.list_scenarios` or a
      :class:`~hev_thermal_env.scenarios.Scenario`.
    * ``config``: the :class:`~hev_thermal_env.physics.VehicleConfig` (default ``paper_bus(physics=physics)``).
    * ``physics``: the physics version, 1 or 2 (set by the id): the default vehicle's parameters and the reward's
      defaults (:meth:`~hev_thermal_env.envs.reward.RewardParams.for_physics`).
    * ``conditions``: fixed :class:`~hev_thermal_env.physics.Conditions` for every episode (overrides the scenario).
    * ``reward``: :class:`~hev_thermal_env.envs.reward.RewardParams` or a dict of its fields (over the version's).
    * ``preview_s``, ``preview_step_s``: length and spacing of the speed preview (integers, seconds); ``preview_s=0``
      removes it.
    * ``render_mode``: ``None``, ``"rgb_array"`` (an H×W×3 uint8 plot of speed, SOC, motor temperature, heat index and
      split so far) or ``"human"`` (the same in a matplotlib window, redrawn at every step and reset).
    * ``thermal``: if given, sets ``config.thermal.enabled`` (default None: the config's own setting); False is the
      paper's unmodified ADVISOR motor (no derating, no extra loss, no cutoff), the baseline of its tables.
    * ``random_start``: start each episode at a uniformly drawn second of the cycle (training).
    * ``soc_offset``: start each episode up to this much SOC (uniform, at most 0.2, clipped to the battery's window)
      off its SOC target, the scenario's initial SOC, to which the reward's band and the observation still refer; a
      reset's ``initial_soc`` option is never shifted. 0 (default): on the target.
    * ``info_keys``: the info keys reported at steps and resets, in their order: ``"all"`` (default) or a sequence of
      names from :data:`~hev_thermal_env.envs.spaces.INFO_KEYS`; ``()``, none, is the lean path for trainers that read
      none.

    ``reset(seed=None, options=None)`` accepts the options ``cycle`` (as the argument, this episode only),
    ``ambient_temp_c``, ``initial_motor_temp_c``, ``initial_soc``, ``coolant`` (``"on"``, ``"degraded"``, ``"off"``) and
    ``start_s`` (whole seconds into the cycle).

    ## Attributes for strategies (``env.unwrapped``)

    ``config``, ``core`` (:class:`~hev_thermal_env.physics.PhysicsCore`), ``conditions`` and ``cycle`` of the episode,
    ``k`` (index of the next step), ``phys_state`` ((1, N_STATE) state before the next step), ``cond`` ((1, N_COND)),
    ``reward_params``, ``soc_target``, ``last_out`` ((N_OUT,) outputs of the last step, zeros after reset) and
    :meth:`peek`, which evaluates candidate actions for the next step without changing the env.

    ## Version History

    * v2: physics v2: the motor rated where its nameplate says (docs/thermal_model.md, *The rated condition*), the
      overheat price the winding insulation's life (docs/environment.md), in traction u ≥ 0.9 stops the engine (v1:
      only u = 1) and a charge yields to the demand before the trace is missed; the MDP is otherwise v1's.
    * v1: the motor thermal network with physical parameters, the action governs braking, observation entry 7
      (winding temperature), the safety cost ``cost``, numpy-scalar infos with the same keys at reset as at every step
      (CHANGELOG.md). ``gymnasium.make("HevThermal-v0")`` raises gymnasium's ``DeprecatedEnv`` naming the newest id.
    * v0: initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}

    def __init__(self, cycle: Any = "hwfet", scenario: str | Scenario = "paper", config: VehicleConfig | None = None,
                 conditions: Conditions | None = None, reward: RewardParams | dict | None = None, preview_s: int = 10,
                 preview_step_s: int = 2, render_mode: str | None = None, thermal: bool | None = None,
                 random_start: bool = False, info_keys: str | Sequence[str] = "all", soc_offset: float = 0.0,
                 physics: int = 2):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self.observation_space, self.action_space = self._build(1, cycle, scenario, config, conditions, reward,
                                                                preview_s, preview_step_s, thermal, random_start,
                                                                info_keys, soc_offset, physics)
        self._u = np.zeros(1)
        self._history: dict[str, list] | None = None
        self._episode_info: dict[str, Any] = {}
        self._plot = None

    # -- contract attributes ---------------------------------------------------------------------

    cycle = property(lambda self: self._rows.cycles[0], doc="The episode's cycle (None before the first reset).")
    conditions = property(lambda self: self._rows.conditions[0], doc="The episode's conditions.")

    @property
    def k(self) -> int:
        """Index of the next step (from ``cycle.speed_mps[k]`` to ``[k+1]``)."""
        return int(self._rows.k[0])

    @property
    def soc_target(self) -> float:
        """SOC target of the reward's deviation term: the episode's initial SOC before any ``soc_offset``."""
        return float(self._rows.soc_target[0])

    @property
    def last_out(self) -> np.ndarray:
        """Outputs (N_OUT,) of the last step (zeros after reset); columns in ``physics.core.OUT_NAMES``."""
        return self._rows.last_out[0]

    # -- gymnasium API ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._rows.last_out = np.zeros((1, core.N_OUT))  # a fresh array: references to the last one stay valid
        info, = self._start([0], [self.np_random], [options])
        obs = self._rows.observe()[0]
        self._episode_info = {key: info[key] for key in spaces.EPISODE_INFO_KEYS}
        if self.render_mode is not None:
            self._history = {name: [] for name in _HISTORY_KEYS}
            self._record(info, motor_share=math.nan)
        if self.info_keys is not spaces.INFO_KEYS:
            info = {key: info[key] for key in self.info_keys}
        return obs, info

    def step(self, action):
        u, clipped = check_action(action)
        rows = self._rows
        if rows.cycles[0] is None:
            raise RuntimeError("call reset() before step()")
        if rows.k[0] >= rows.end[0]:
            raise RuntimeError("the episode has ended (truncated at the end of the cycle); call reset()")
        self._u[0] = u
        reward, terms, out, obs = rows.step(self._u)
        k = int(rows.k[0])
        truncated = k >= rows.end[0]
        info = {}
        if self.info_keys or self._history is not None:
            info = spaces.step_info(out[0], rows.state[0], terms[0], rows.speed[0, k], k, u,
                                    np.True_ if clipped else np.False_, self._episode_info, self._cost_step_s)
            if self._history is not None:
                self._record(info)
            if self.info_keys is not spaces.INFO_KEYS:
                info = {key: info[key] for key in self.info_keys}
        return obs[0], float(reward[0]), False, bool(truncated), info

    def peek(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate candidate actions for the next step from the current state, without changing the env.

        ``actions``: n motor shares (any shape with n elements; clipped to [-1, 1] by the core). Returns
        ``(state_out [n, N_STATE], out [n, N_OUT])`` from one batched call of the physics core.
        """
        a = np.array(actions, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(a)):
            raise ValueError("peek: actions contain NaN or inf")
        rows = self._rows
        if rows.cycles[0] is None or rows.k[0] >= rows.end[0]:
            raise RuntimeError("peek: no next step (call reset() first)")
        k = int(rows.k[0])
        return self.core.step(np.repeat(rows.state, a.size, axis=0), a, rows.speed[0, k], rows.speed[0, k + 1],
                              rows.grade[0, k], rows.cond[0])

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self._plot is None:
            self._plot = EpisodePlot(human=self.render_mode == "human", fps=self.metadata["render_fps"])
        self._plot.draw(self._history or {}, self.cycle, self.config, f"HevThermal-v{self.physics}")
        return self._plot.to_rgb() if self.render_mode == "rgb_array" else None

    def close(self):
        if self._plot is not None:
            self._plot.close()
            self._plot = None

    def _record(self, info: dict[str, Any], **first: float) -> None:
        """Append a step's (or with ``first``, a reset's) values to the rendering history; redraw a human window."""
        for name, values in self._history.items():
            values.append(first[name] if name in first else info[name])
        if self.render_mode == "human":
            self.render()


#: What the rendering history records (only with a render_mode), per step.
_HISTORY_KEYS = ("time_s", "cycle_speed_mps", "speed_mps", "soc", "motor_temp_c", "heat_index", "motor_share")


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
