"""The evaluation during training: deterministic runs of the current policy on cycles it does not train on."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hev_thermal_env.cycles import expand_cycle_names, load_cycle
from hev_thermal_env.envs import HevThermalVectorEnv
from hev_thermal_env.metrics import run_metrics
from hev_thermal_env.physics import core

from .envs import env_kwargs

#: The per-step info fields the metrics need.
TRACE_KEYS = ("fuel_g", "battery_chem_power_w", "missed_wheel_energy_j", "soc", "motor_temp_c", "heat_index",
              "motor_cutoff", "trace_miss_mps", "engine_on")
#: The metrics of each evaluation run.
METRIC_KEYS = ("fuel_corrected_l_per_100km", "delta_soc", "cutoff_s", "trace_miss_max_mps")


class PolicyEvaluator:
    """Deterministic runs of a policy over fixed cycles (sets expanded) × scenarios, all cycles of a scenario in one
    :class:`~hev_thermal_env.envs.HevThermalVectorEnv` with the run's env settings, from the cycle's start (random
    scenarios draw from ``seed``); the metrics are ``run_strategy``'s (:func:`hev_thermal_env.metrics.run_metrics`).
    """

    def __init__(self, env_cfg: dict[str, Any], cycles: Sequence[str], scenarios: Sequence[str], seed: int = 0):
        self.env_cfg = env_cfg
        self.cycle_names = [str(c) for c in expand_cycle_names(list(cycles))]  # sets (validation_bus) expanded
        self.cycles = [load_cycle(c) for c in self.cycle_names]
        self.scenarios = list(scenarios)
        self.seed = int(seed)

    def run(self, act: Callable[[np.ndarray], np.ndarray],
            reset: Callable[[], None] | None = None) -> list[dict[str, Any]]:
        """Drive every (cycle, scenario) with ``act(raw_obs [n, dim]) -> actions [n, 1]``; one result per run.

        ``reset()`` is called before each scenario's episodes start (a recurrent policy forgets its state); by default
        ``act``'s owner's ``reset_state`` when ``act`` is a method of an object that has one
        (:class:`~hev_thermal_env.agents.policy_files.LoadedPolicy`)."""
        if reset is None:
            reset = getattr(getattr(act, "__self__", None), "reset_state", None)
        return [r for scenario in self.scenarios for r in self.run_scenario(act, scenario, reset)]

    def run_scenario(self, act: Callable[[np.ndarray], np.ndarray], scenario: str,
                     reset: Callable[[], None] | None = None) -> list[dict[str, Any]]:
        """Every cycle in ``scenario``, in one batched env, after ``reset()`` (if given)."""
        kwargs = env_kwargs({**self.env_cfg, "scenario": scenario}, for_eval=True)
        n = len(self.cycles)
        venv = HevThermalVectorEnv(n, **{**kwargs, "cycle": self.cycles})
        obs, _ = venv.reset(seed=self.seed, options=[{"cycle": c} for c in self.cycles])
        soc0 = venv.phys_state[:, core.SOC].copy()
        if reset is not None:
            reset()
        lengths = np.array([c.n_steps for c in self.cycles])
        horizon = int(lengths.max())
        traces, returns = {k: np.zeros((horizon, n)) for k in TRACE_KEYS}, np.zeros(n)
        for t in range(horizon):
            obs, reward, _, _, info = venv.step(act(obs))
            returns += np.where(t < lengths, reward, 0.0)
            for k in TRACE_KEYS:
                traces[k][t] = info[k]
        results = []
        for i, (name, cyc) in enumerate(zip(self.cycle_names, self.cycles)):
            m = int(lengths[i])
            s = run_metrics({k: traces[k][:m, i] for k in TRACE_KEYS}, venv.config, float(soc0[i]), cyc.speed_mps, 0,
                            m, venv.core.dt_s)
            results.append({"cycle": name, "scenario": scenario, "return_g": float(returns[i]),
                            **{k: s[k] for k in METRIC_KEYS}})
        venv.close()
        return results
