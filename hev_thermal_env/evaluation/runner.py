"""Run one strategy over one cycle in ``HevThermal-v2`` and report its metrics (:func:`run_strategy`).

The metrics come from :func:`hev_thermal_env.metrics.run_metrics`, so they match the whole-cycle simulation, with
``cost_g``, the yardstick cost of :func:`hev_thermal_env.metrics.yardstick_cost_g` at the env's reward weights.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import time
from typing import Any

import numpy as np

from hev_thermal_env.agents.base import Strategy
from hev_thermal_env.cycles import Cycle, load_cycle
from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.metrics import run_metrics, yardstick_cost_g
from hev_thermal_env.physics import Conditions, VehicleConfig, core, paper_bus
from hev_thermal_env.scenarios import Scenario, get_scenario
from hev_thermal_env.simulate import step_traces

SUMMARY_KEYS = (
    "cycle", "strategy", "scenario", "distance_km", "duration_s", "fuel_g", "fuel_l_per_100km",
    "fuel_corrected_l_per_100km", "soc_correction_l_per_100km", "miss_correction_l_per_100km", "cost_g",
    "battery_energy_kwh", "net_energy_ratio", "charge_sustaining", "missed_wheel_energy_kwh", "soc_initial",
    "soc_final", "delta_soc", "max_motor_temp_c", "heat_index_max", "derated_s", "cutoff_s", "safety_cost_s",
    "trace_miss_max_mps", "engine_on_s", "wall_s", "plan_s", "thermal_aware", "seed", "conditions", "strategy_settings",
)
"""Keys of :attr:`RunResult.summary`, in order."""


@dataclasses.dataclass
class RunResult:
    """The summary (JSON-ready dict) and per-step traces (arrays of length n_steps) of one run."""

    summary: dict[str, Any]
    trace: dict[str, np.ndarray]
    info_keys: tuple[str, ...] = ()

    def to_json_dict(self) -> dict[str, Any]:
        return jsonable(self.summary)

    def trace_csv(self) -> str:
        """The per-second trace as CSV text: the env's ``info`` fields, then the action."""
        keys = tuple(k for k in self.info_keys if k in self.trace)
        buf = io.StringIO()
        rows = ([_fmt(v) for v in row] for row in zip(*(np.asarray(self.trace[k]) for k in keys)))
        csv.writer(buf, lineterminator="\n").writerows([keys, *rows])
        return buf.getvalue()


def _fmt(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    f = float(v)
    return repr(int(f)) if f.is_integer() and abs(f) < 1e15 else f"{f:.9g}"


def jsonable(x: Any) -> Any:
    """``x`` with numpy values as Python's and a non-finite float as None (strict JSON)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.ndarray, np.generic)):
        return jsonable(x.tolist())
    if isinstance(x, float):
        return float(x) if np.isfinite(x) else None
    return x


def run_strategy(strategy: Strategy, cycle: str | Cycle | Any, scenario: str | Scenario = "paper", *,
                 config: VehicleConfig | None = None, conditions: Conditions | None = None,
                 seed: int = 0, physics: int = 2) -> RunResult:
    """Drive ``cycle`` (a built-in name, a CSV path or a :class:`~hev_thermal_env.cycles.Cycle`) with ``strategy``
    in the ``scenario`` (``"random"`` draws from the env's reset ``seed``) or explicit ``conditions``; ``config``: the
    vehicle before the strategy's change (default ``paper_bus(physics=physics)``); ``physics``: the env's physics
    version. ``trace`` holds every ``info`` field, every physics output, the state after each step and ``u``."""
    scen = get_scenario(scenario)
    cyc = load_cycle(cycle)
    t_start = time.perf_counter()
    vehicle = strategy.vehicle_config(config if config is not None else paper_bus(physics=physics))
    env = HevThermalEnv(cycle=cyc, scenario=scen, config=vehicle, conditions=conditions, physics=physics,
                        **strategy.env_options())
    try:
        obs, info = env.reset(seed=seed)
        e = env.unwrapped
        soc0 = float(e.phys_state[0, core.SOC])
        k0 = int(e.k)
        t_plan = time.perf_counter()
        strategy.reset(env)
        plan_s = time.perf_counter() - t_plan
        n = e.cycle.n_steps - k0
        outs, states, us = np.empty((n, core.N_OUT)), np.empty((n, core.N_STATE)), np.empty(n)
        infos: dict[str, list] = {}
        for i in range(n):
            action = np.asarray(strategy.act(obs, info), dtype=np.float32).reshape(1)
            obs, _, terminated, truncated, info = env.step(action)
            outs[i] = e.last_out
            states[i] = e.phys_state[0]
            us[i] = float(action[0])
            for key, value in info.items():
                infos.setdefault(key, []).append(value)
            if terminated or truncated:
                break
        steps = i + 1
        wall = time.perf_counter() - t_start
    finally:
        env.close()
    trace = step_traces(outs[:steps], states[:steps])
    for key, values in infos.items():
        trace[key] = np.asarray(values)
    trace["u"] = us[:steps]
    metrics = run_metrics(trace, e.config, soc0, e.cycle.speed_mps, k0, steps, e.core.dt_s)
    metrics["cost_g"] = yardstick_cost_g(outs[:steps], states[:steps], e.reward_params,
                                         e.config.engine.fuel_lhv_j_per_g, e.core.dt_s, e.soc_target)
    summary = {"cycle": e.cycle.name, "strategy": getattr(strategy, "label", strategy.name), "scenario": scen.name,
               **metrics, "wall_s": wall, "plan_s": plan_s, "thermal_aware": bool(strategy.thermal_aware),
               "seed": seed, "conditions": e.conditions.to_dict(), "strategy_settings": strategy.describe()}
    summary = {k: summary[k] for k in SUMMARY_KEYS if k in summary} | {k: v for k, v in summary.items()
                                                                        if k not in SUMMARY_KEYS}
    return RunResult(summary=jsonable(summary), trace=trace, info_keys=tuple(infos) + ("u",))
