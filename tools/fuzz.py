"""Reliability checks: random-action fuzzing of the environment against physical invariants.

:func:`fuzz` drives the native vector environment with random actions (the bounds and beyond) over every built-in
cycle, scenario and random bus cycles and checks every step: no NaN or inf, observations in their space, SOC in the
battery's hard window, heat index in [0, 1], no negative fuel, the motor never below its coolest heat sink (ambient,
coolant, its start) minus :data:`TEMP_TOL_C`, and the battery's chemical power equal to −ΔSOC·capacity·V_oc
(coulomb counting from the SOC itself: a SOC held in its window by a clamp while current flows fails here); and the
energy balance of every episode within :data:`BALANCE_TOL`. The long run: ``python benchmarks/fuzz.py``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from hev_thermal_env.cycles import list_cycles
from hev_thermal_env.envs import HevThermalVectorEnv
from hev_thermal_env.physics import battery, core
from hev_thermal_env.scenarios import list_scenarios

#: Steps whose energy balance, summed over an episode, may miss by this fraction of the energy in and out.
BALANCE_TOL = 0.005
#: The motor may end a step this far below its coolest heat sink (°C).
TEMP_TOL_C = 1e-6


def _balance_terms(out: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    e_in = out[:, core.ENGINE_POWER] + out[:, core.BATT_CHEM]
    e_out = (out[:, core.WHEEL_POWER] + out[:, core.BRAKE_POWER] + out[:, core.BATT_LOSS] + out[:, core.MOTOR_LOSS]
             + out[:, core.CLUTCH_LOSS] + out[:, core.DRIVELINE_LOSS] + out[:, core.ACC])
    scale = np.abs(out[:, core.ENGINE_POWER]) + np.abs(out[:, core.BATT_CHEM])
    return e_in, e_out, scale


def fuzz(n_steps: int = 100_000, *, num_envs: int = 64, seed: int = 0, progress: bool = False) -> dict[str, Any]:
    """Run about ``n_steps`` random env-steps, shared by the scenarios; raise AssertionError on the first violation.
    Returns counts and the worst values seen (steps, episodes, max energy-balance error, SOC range...)."""
    scenarios = list_scenarios()
    cycles = list_cycles() + ["random_bus"]
    rng = np.random.default_rng(seed)
    report: dict[str, Any] = {"steps": 0, "episodes": 0, "max_balance_error": 0.0, "soc_min": 1.0, "soc_max": 0.0,
                              "temp_min_margin_c": np.inf, "temp_max_c": -np.inf, "cutoff_steps": 0,
                              "derated_steps": 0, "scenarios": scenarios, "cycles": cycles}
    per_scenario = max(n_steps // len(scenarios), num_envs)
    t0 = time.perf_counter()
    for si, scenario in enumerate(scenarios):
        _fuzz_scenario(scenario, cycles, num_envs, seed * 1000 + si, per_scenario, rng, report)
        if progress:
            print(f"  {scenario}: {report['steps']:,} steps so far ({time.perf_counter() - t0:.1f} s)")
    report["wall_s"] = time.perf_counter() - t0
    report["steps_per_s"] = report["steps"] / report["wall_s"]
    return report


def _fuzz_scenario(scenario: str, cycles: list[str], num_envs: int, seed: int, n_steps: int,
                   rng: np.random.Generator, report: dict[str, Any]) -> None:
    """At least ``n_steps`` random steps of one scenario, checked step by step and episode by episode."""
    env = HevThermalVectorEnv(num_envs, cycle=cycles, scenario=scenario, random_start=True)
    env.reset(seed=seed)
    balance = np.zeros((3, num_envs))  # energy in, energy out, scale, summed over the episode
    resetting = np.zeros(num_envs, dtype=bool)
    sink = _sinks(env)
    # a third of the episodes keep a sustained aggressive assist, to reach derating and cutoff
    aggressive = rng.random(num_envs) < 0.33
    done_steps = 0
    while done_steps < n_steps:
        soc_before = env.phys_state[:, core.SOC].copy()
        obs, rew, term, trunc, info = env.step(_random_actions(rng, aggressive)[:, None])
        stepped = ~resetting
        soc, temp, margin = _check_step(scenario, env, obs, rew, info, sink, stepped, soc_before)
        balance[:, stepped] += np.array(_balance_terms(env.last_out))[:, stepped]
        ended = (term | trunc) & stepped
        for i in np.flatnonzero(ended):
            err = abs(balance[0, i] - balance[1, i]) / max(balance[2, i], 1.0)
            report["max_balance_error"] = max(report["max_balance_error"], float(err))
            if err > BALANCE_TOL:
                raise AssertionError(f"{scenario}: energy balance off by {err:.3%} over an episode")
            report["episodes"] += 1
        balance[:, ended] = 0.0
        n_live = int(stepped.sum())
        done_steps += n_live
        report["steps"] += n_live
        report["soc_min"] = min(report["soc_min"], float(soc[stepped].min(initial=1.0)))
        report["soc_max"] = max(report["soc_max"], float(soc[stepped].max(initial=0.0)))
        if n_live:
            report["temp_min_margin_c"] = min(report["temp_min_margin_c"], float(margin[stepped].min()))
            report["temp_max_c"] = max(report["temp_max_c"], float(temp[stepped].max()))
        report["cutoff_steps"] += int(info["motor_cutoff"][stepped].sum())
        report["derated_steps"] += int((info["heat_index"][stepped] > 0).sum())
        # NEXT_STEP autoreset: the next step of an ended env is its reset
        if np.any(resetting):
            sink = np.where(resetting, _sinks(env), sink)
            aggressive = np.where(resetting, rng.random(num_envs) < 0.33, aggressive)
        resetting = term | trunc
    env.close()


def _random_actions(rng: np.random.Generator, aggressive: np.ndarray) -> np.ndarray:
    """Motor shares: the bounds, zero, beyond the bounds (clipped by the env) and uniform; a sustained assist for
    the ``aggressive`` rows."""
    n = aggressive.size
    kind = rng.random(n)
    act = rng.uniform(-1.0, 1.0, n)
    act[kind < 0.1] = -1.0
    act[(kind >= 0.1) & (kind < 0.2)] = 1.0
    act[(kind >= 0.2) & (kind < 0.25)] = 0.0
    big = (kind >= 0.25) & (kind < 0.35)
    act[big] = rng.uniform(-5.0, 5.0, int(big.sum()))
    act = np.where(aggressive & (kind >= 0.35), rng.uniform(0.7, 1.0, n), act)
    return act.astype(np.float32)


def _check_step(scenario: str, env, obs, rew, info, sink, stepped, soc_before):
    """The per-step invariants of a vector-env step; returns SOC, temperature and its margin above the sink."""
    out, state = env.last_out, env.phys_state
    bat = env.config.battery
    space = env.single_observation_space
    _check_finite(obs, rew, info, out)
    inside = (obs >= space.low) & (obs <= space.high)
    if not np.all(inside):
        bad = np.argwhere(~inside)[0]
        raise AssertionError(f"{scenario}: observation {bad[1]} = {obs[bad[0], bad[1]]} outside its bounds")
    soc = state[:, core.SOC]
    if np.any(soc < bat.soc_min - 1e-12) or np.any(soc > bat.soc_max + 1e-12):
        raise AssertionError(f"{scenario}: SOC {soc.min()}..{soc.max()} left [{bat.soc_min}, {bat.soc_max}]")
    voc_table = env.core.ba[battery.IDX.voc_v:battery.IDX.voc_v + battery.N_SOC]
    voc = np.interp(soc_before, np.linspace(0.0, 1.0, battery.N_SOC), voc_table)
    chem_from_soc = -(soc - soc_before) * env.core.ba[battery.IDX.capacity_as] * voc / env.core.dt_s
    chem_err = np.abs(chem_from_soc - out[:, core.BATT_CHEM])[stepped]
    if chem_err.size and chem_err.max() > 1e-6 * max(float(np.abs(out[:, core.BATT_CHEM]).max()), 1.0):
        raise AssertionError(f"{scenario}: battery chemical power differs from −ΔSOC·capacity·V_oc by "
                             f"{chem_err.max():.3g} W")
    hi = info["heat_index"]
    if np.any(hi < 0) or np.any(hi > 1):
        raise AssertionError(f"{scenario}: heat index {hi.min()}..{hi.max()} outside [0, 1]")
    if np.any(info["fuel_g"] < 0):
        raise AssertionError(f"{scenario}: negative fuel {info['fuel_g'].min()}")
    temp = state[:, core.TEMP_C]
    margin = temp - sink
    if np.any(margin[stepped] < -TEMP_TOL_C):
        i = int(np.argmin(np.where(stepped, margin, np.inf)))
        raise AssertionError(f"{scenario}: motor at {temp[i]:.6f} °C below its coolest heat sink {sink[i]:.6f}")
    return soc, temp, margin


def _sinks(env) -> np.ndarray:
    """Per env: the coolest temperature the motor can be drawn toward in this episode."""
    start = np.array([c.initial_motor_temp_c for c in env.conditions])
    return np.minimum(np.minimum(env.cond[:, core.AMBIENT_C], env.cond[:, core.WATER_C]), start)


def _check_finite(obs, rew, info, out) -> None:
    for what, x in (("an observation", obs), ("a reward", rew), ("a physics output", out)):
        if not np.all(np.isfinite(x)):
            raise AssertionError(f"NaN or inf in {what}")
    for key, val in info.items():
        numeric = not key.startswith("_") and isinstance(val, np.ndarray) and val.dtype.kind in "fiub"
        if numeric and not np.all(np.isfinite(val)):
            raise AssertionError(f"NaN or inf in info[{key!r}]")
