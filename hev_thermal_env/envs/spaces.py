"""The observation and info layout of ``HevThermal-v2``: names and bounds, the info builders, the safety cost and codes,
shared by the single env, the batch engine and the vector env.

``info["cycle_id"]`` → :func:`cycle_name`: the built-in cycles have fixed ids, their order in
:func:`hev_thermal_env.cycles.list_cycles`; any other cycle gets the next free id the first time the process meets its
name, so its id is valid only in that process. ``info["coolant_code"]`` → :func:`coolant_mode`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..cycles import list_cycles
from ..physics import core
from ..physics.config import COOLANT_MODES, VehicleConfig
from .reward import REWARD_TERMS

RPM_PER_RADPS = 30.0 / math.pi

# The observation: (name, low, high) in order; ``None`` bounds are filled from the vehicle (meaning and unit: the
# observation table of :class:`~hev_thermal_env.envs.HevThermalEnv`).
_OBS_FIELDS = (
    ("speed_mps", 0.0, 60.0), ("accel_mps2", -10.0, 10.0), ("wheel_power_demand_kw", -2000.0, 2000.0),
    ("soc", 0.0, 1.0), ("soc_target", 0.0, 1.0), ("soc_deviation", -1.0, 1.0), ("motor_temp_c", -40.0, 200.0),
    ("winding_temp_c", -40.0, 250.0), ("heat_index", 0.0, 1.0), ("heat_x", -1.0, 1.0), ("motor_cutoff", 0.0, 1.0),
    ("motor_torque_avail_nm", 0.0, None), ("gear", 0.0, None), ("cycle_progress", 0.0, 1.0),
    ("ambient_temp_c", -40.0, 60.0), ("coolant_factor", 0.0, 1.0),
)
N_OBS_BASE = len(_OBS_FIELDS)
# in _OBS_FIELDS' order:
(OBS_SPEED, OBS_ACCEL, OBS_DEMAND, OBS_SOC, OBS_SOC_TARGET, OBS_SOC_DEVIATION, OBS_TEMP, OBS_WINDING, OBS_PWM,
 OBS_HEAT_X, OBS_CUTOFF, OBS_AVAIL, OBS_GEAR, OBS_PROGRESS, OBS_AMBIENT, OBS_COOLANT) = range(N_OBS_BASE)

_REWARD_KEYS = ("reward_fuel", "reward_overheat", "reward_soc", "reward_miss")  # the documented contract order
_REWARD_COLUMNS = tuple((key, REWARD_TERMS.index(key)) for key in _REWARD_KEYS)

EPISODE_INFO_KEYS = ("cycle_id", "start_s", "soc_target", "ambient_temp_c", "coolant_code")
"""Keys of the info that hold the episode's cycle, start and conditions (the same at its reset and every step)."""

INFO_KEYS = (
    "fuel_g", "soc", "motor_temp_c", "heat_index", "motor_torque_nm", "motor_speed_rpm", "motor_heat_w",
    "engine_torque_nm", "engine_speed_rpm", "engine_on", "gear", "speed_mps", "trace_miss_mps", "motor_cutoff",
    "coolant_on", "winding_temp_c", "coolant_temp_c", "winding_trip", *_REWARD_KEYS, "cost", "missed_wheel_energy_j",
    "battery_chem_power_w", "battery_power_w", "motor_torque_avail_nm", "cycle_speed_mps", "time_s", "motor_share",
    "motor_share_clipped", "motor_torque_clipped", *EPISODE_INFO_KEYS,
)
"""Keys of the ``info`` dict of every reset and every step, in this order (the documented contract first, then
extras); the values are numpy scalars of :data:`INFO_DTYPES`."""

_INT_KEYS = ("gear", "cycle_id", "start_s", "coolant_code")
_BOOL_KEYS = ("engine_on", "motor_cutoff", "coolant_on", "winding_trip", "motor_share_clipped", "motor_torque_clipped")
INFO_DTYPES: dict[str, type] = {key: np.int64 if key in _INT_KEYS else np.bool_ if key in _BOOL_KEYS else np.float64
                                for key in INFO_KEYS}
"""The numpy type of each info value (``np.float64``, ``np.int64`` or ``np.bool_``), at resets and steps alike, and
the dtype of the vector env's info arrays."""

#: Keys whose reset value is the episode's starting state (the others are quantities of a step: zero or False at a
#: reset): the state, the vehicle's speed, the clock, the motor's torque envelope of the first step (the
#: observation's entry ``motor_torque_avail_nm``) and the episode's keys.
STATE_INFO_KEYS = ("soc", "motor_temp_c", "heat_index", "motor_cutoff", "winding_temp_c", "coolant_temp_c",
                   "winding_trip", "speed_mps", "motor_torque_avail_nm", "cycle_speed_mps", "time_s",
                   *EPISODE_INFO_KEYS)


def safety_cost(heat_index: Any, cutoff: Any, winding_trip: Any, dt_s: float) -> Any:
    """The safety cost of steps (``info["cost"]``, the env's spec, section Cost): ``dt_s · max(PWM, stopped)``, PWM
    the heat index after the step (eq 9), ``stopped`` either protection (``cutoff``: 70 °C, ``winding_trip``: 165 °C
    winding); ``dt_s`` 0 for a motor without the thermal model (nothing derates or stops). Arrays, or numpy scalars."""
    if isinstance(heat_index, np.ndarray):
        return np.maximum(heat_index, np.maximum(cutoff, winding_trip)) * dt_s
    return max(heat_index, cutoff, winding_trip) * dt_s  # one step: a tenth of the ufuncs' time


_CYCLE_NAMES: list[str] = list(list_cycles())
_CYCLE_IDS: dict[str, int] = {name: i for i, name in enumerate(_CYCLE_NAMES)}


def check_info_keys(info_keys: Any) -> tuple[str, ...]:
    """The info keys an env reports, at steps and resets: ``"all"`` (:data:`INFO_KEYS`) or a sequence of them
    (``()``: none)."""
    if isinstance(info_keys, str):
        if info_keys != "all":
            raise ValueError(f"info_keys: 'all' or a sequence of info keys, got {info_keys!r}")
        return INFO_KEYS
    try:
        keys = tuple(info_keys)
    except TypeError:
        raise ValueError(f"info_keys: 'all' or a sequence of info keys, got {info_keys!r}") from None
    unknown = [k for k in keys if k not in INFO_KEYS]
    if unknown:
        raise ValueError(f"info_keys: unknown key(s) {unknown}; known: {', '.join(INFO_KEYS)}")
    return keys


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
    high = [fill.get(f[0], f[2]) for f in _OBS_FIELDS] + [60.0] * n_preview  # the preview: speeds, as entry 0
    return np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)


def step_info(out: np.ndarray, state: np.ndarray, terms: np.ndarray, cycle_speed: Any, time_s: Any, u: Any,
              clipped: Any, episode: dict[str, Any], cost_step: float) -> dict[str, Any]:
    """The ``info`` of a step in :data:`INFO_KEYS` order, of the types of :data:`INFO_DTYPES`: of one step from the
    rows ``out`` [N_OUT], ``state`` [N_STATE] and ``terms`` [4] (numpy scalars; ``clipped`` an ``np.bool_``), or of a
    batch from their transposes (``out.T`` ...: an array per key, a column view where the dtype allows).
    ``episode``: the :data:`EPISODE_INFO_KEYS` values, taken as they are; ``cost_step``: the ``dt_s`` of
    :func:`safety_cost`."""
    info = {
        "fuel_g": out[core.FUEL_G], "soc": state[core.SOC], "motor_temp_c": state[core.TEMP_C],
        "heat_index": out[core.HEAT_INDEX], "motor_torque_nm": out[core.MOTOR_TORQUE],
        "motor_speed_rpm": out[core.MOTOR_SPEED] * RPM_PER_RADPS, "motor_heat_w": out[core.MOTOR_HEAT],
        "engine_torque_nm": out[core.ENGINE_TORQUE], "engine_speed_rpm": out[core.ENGINE_SPEED] * RPM_PER_RADPS,
        "engine_on": out[core.ENGINE_ON] != 0.0, "gear": _int64(out[core.GEAR]), "speed_mps": out[core.SPEED],
        "trace_miss_mps": out[core.TRACE_MISS], "motor_cutoff": state[core.CUTOFF] != 0.0,
        "coolant_on": out[core.COOLANT_ON] != 0.0, "winding_temp_c": state[core.WINDING_C],
        "coolant_temp_c": state[core.COOLANT_C], "winding_trip": state[core.WINDING_TRIP] != 0.0,
    }
    for key, col in _REWARD_COLUMNS:
        info[key] = terms[col]
    info.update(
        cost=safety_cost(out[core.HEAT_INDEX], state[core.CUTOFF], state[core.WINDING_TRIP], cost_step),
        missed_wheel_energy_j=out[core.MISSED_J], battery_chem_power_w=out[core.BATT_CHEM],
        battery_power_w=out[core.BATT_POWER], motor_torque_avail_nm=out[core.MOTOR_AVAIL],
        cycle_speed_mps=np.float64(cycle_speed), time_s=np.float64(time_s), motor_share=np.float64(u),
        motor_share_clipped=clipped, motor_torque_clipped=out[core.MOTOR_CLIPPED] != 0.0)
    info.update(episode)
    return info


_SMALL_INT64 = tuple(np.int64(i) for i in range(64))


def _int64(x: Any) -> Any:
    """``x`` as int64: an array cast, a scalar (a gear or a code) from a table of the small ones (a fifth of the
    constructor's time)."""
    if type(x) is np.ndarray:
        return x.astype(np.int64)
    i = int(x)
    return _SMALL_INT64[i] if 0 <= i < 64 else np.int64(i)


def reset_info_dict(rows: Any, i: int, ep: Any) -> dict[str, Any]:
    """The ``info`` of a reset: row ``i`` of the batch engine ``rows`` starting episode ``ep``. The keys and types of a
    step's; the keys of :data:`STATE_INFO_KEYS` hold the starting state, the others (quantities of a step) zero or
    False."""
    st = rows.state[i]
    k = int(rows.k[i])
    out = np.zeros(core.N_OUT)
    out[core.SPEED] = rows.speed[i, k]
    out[core.MOTOR_AVAIL] = rows.avail[i]
    out[core.HEAT_INDEX] = min(max(st[core.HEAT_X], 0.0), 1.0)
    episode = {"cycle_id": np.int64(cycle_id(ep.cycle.name)), "start_s": np.int64(ep.start_s),
               "soc_target": np.float64(rows.soc_target[i]), "ambient_temp_c": np.float64(ep.conditions.ambient_temp_c),
               "coolant_code": np.int64(coolant_code(ep.conditions.coolant))}
    # cost_step 0: the safety cost, too, is a quantity of a step
    return step_info(out, st, np.zeros(len(REWARD_TERMS)), rows.speed[i, k], k, 0.0, np.False_, episode, 0.0)


def cycle_id(name: str) -> int:
    """The id of the cycle called ``name`` (a new one, from the next free number, for a name not seen yet)."""
    code = _CYCLE_IDS.get(name)
    if code is None:
        code = _CYCLE_IDS[name] = len(_CYCLE_NAMES)
        _CYCLE_NAMES.append(name)
    return code


def cycle_name(code: int) -> str:
    """The name of the cycle with id ``code`` (``info["cycle_id"]`` of a reset)."""
    i = int(code)
    if not 0 <= i < len(_CYCLE_NAMES):
        raise KeyError(f"cycle id {code!r} is not known in this process (ids 0-{len(_CYCLE_NAMES) - 1}); "
                       "ids of cycles other than the built-in ones are given by the process that runs the env: "
                       "read env.unwrapped.cycle.name there")
    return _CYCLE_NAMES[i]


def coolant_code(mode: str) -> int:
    """The code of a coolant mode (``"on"`` 0, ``"degraded"`` 1, ``"off"`` 2)."""
    return COOLANT_MODES.index(mode)


def coolant_mode(code: int) -> str:
    """The coolant mode of ``info["coolant_code"]``."""
    i = int(code)
    if not 0 <= i < len(COOLANT_MODES):
        raise KeyError(f"coolant code {code!r}: expected 0-{len(COOLANT_MODES) - 1} ({', '.join(COOLANT_MODES)})")
    return COOLANT_MODES[i]
