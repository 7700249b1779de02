"""The environments of a run: the training VecEnv of its config (the native vector env through its SB3 adapter,
:class:`~hev_thermal_env.wrappers.sb3.Sb3VecEnv`, timed, for a constrained algorithm with the safety cost priced in,
:mod:`.lagrangian`, and its ``VecNormalize``), the evaluation during training (:class:`PolicyEvaluator`) and the final
validation of the best and final models (:func:`final_validation`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor, VecNormalize

from hev_thermal_env.agents.policy_files import load_policy
from hev_thermal_env.cycles import expand_cycle_names, load_cycle
from hev_thermal_env.envs import HevThermalVectorEnv
from hev_thermal_env.metrics import run_metrics
from hev_thermal_env.physics import core
from hev_thermal_env.wrappers.sb3 import Sb3VecEnv

from .artifacts import write_csv
from .lagrangian import LagrangeMultiplier, LagrangianVecEnv
from .selection import run_key

#: The per-step info fields the metrics need.
TRACE_KEYS = ("fuel_g", "battery_chem_power_w", "missed_wheel_energy_j", "soc", "motor_temp_c", "heat_index",
              "motor_cutoff", "trace_miss_mps", "engine_on")
#: The metrics of each evaluation run.
METRIC_KEYS = ("fuel_corrected_l_per_100km", "delta_soc", "cutoff_s", "trace_miss_max_mps")
VALIDATION_COLUMNS = ("model", "cycle", "scenario", "fuel_corrected_l_per_100km", "reference_l_per_100km",
                      "fuel_ratio", "delta_soc", "cutoff_s", "trace_miss_max_mps", "return_g")


def env_kwargs(env_cfg: dict[str, Any], *, for_eval: bool = False) -> dict[str, Any]:
    """Keyword arguments of ``HevThermalEnv`` / ``HevThermalVectorEnv`` for the config's env section."""
    return {"cycle": list(env_cfg["cycles"]), "scenario": env_cfg["scenario"],
            "random_start": False if for_eval else bool(env_cfg.get("random_start", True)),
            "preview_s": int(env_cfg["preview_s"]), "preview_step_s": int(env_cfg["preview_step_s"]),
            "thermal": bool(env_cfg.get("thermal", True)), "reward": dict(env_cfg.get("reward") or {}),
            "soc_offset": 0.0 if for_eval else float(env_cfg.get("soc_offset", 0.0))}


class TimedVecEnv(VecEnvWrapper):
    """Measures the wall time spent in the wrapped env's ``reset`` and ``step`` (``seconds``): the env's share of
    training is reported."""

    def __init__(self, venv):
        super().__init__(venv)
        self.seconds = 0.0

    def _timed(self, method, *args):
        t = time.perf_counter()
        try:
            return method(*args)
        finally:
            self.seconds += time.perf_counter() - t

    def reset(self):
        return self._timed(self.venv.reset)

    def step_async(self, actions):
        self._timed(self.venv.step_async, actions)

    def step_wait(self):
        return self._timed(self.venv.step_wait)


def make_vec_env(config: dict[str, Any]) -> tuple[VecMonitor | LagrangianVecEnv, TimedVecEnv]:
    """The raw training VecEnv of the config (no normalisation), and the timer inside it. ``VecMonitor`` records the
    env's own reward; a constrained run's :class:`~.lagrangian.LagrangianVecEnv` sits above it."""
    constrained = config.get("constraint") is not None
    sb3_env = Sb3VecEnv(int(config["n_envs"]), info_keys=("cost",) if constrained else (), **env_kwargs(config["env"]))
    timed = TimedVecEnv(sb3_env)
    monitored = VecMonitor(timed)
    if constrained:
        c = config["constraint"]
        multiplier = LagrangeMultiplier(c["budget_s_per_h"], c["lambda_lr"], c["lambda_init"], c["lambda_max"])
        n_steps = int(config["hyperparams"].get("n_steps", 2048))
        return LagrangianVecEnv(monitored, multiplier, n_steps, float(sb3_env.venv.core.dt_s)), timed
    return monitored, timed


def wrap_normalize(venv, config: dict[str, Any], stats_path: Path | None = None):
    """``VecNormalize`` over ``venv`` (fresh, or with the statistics saved at ``stats_path``)."""
    norm = config["normalize"]
    if norm is False:
        return venv
    if stats_path is not None:
        vn = VecNormalize.load(str(stats_path), venv)
        vn.training = True
        return vn
    return VecNormalize(venv, gamma=float(config["hyperparams"].get("gamma", 0.99)), **norm)


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

    def run(self, act: Callable[[np.ndarray], np.ndarray]) -> list[dict[str, Any]]:
        """Drive every (cycle, scenario) with ``act(raw_obs [n, dim]) -> actions [n, 1]``; one result per run. Before
        each scenario's episodes start a recurrent policy forgets its state: ``act``'s owner's ``reset_state`` is
        called when it has one (:class:`~hev_thermal_env.agents.policy_files.LoadedPolicy`)."""
        reset = getattr(getattr(act, "__self__", None), "reset_state", None)
        lengths = np.array([c.n_steps for c in self.cycles])
        n, horizon = len(self.cycles), int(lengths.max())
        results = []
        for scenario in self.scenarios:
            kwargs = env_kwargs({**self.env_cfg, "scenario": scenario}, for_eval=True)
            venv = HevThermalVectorEnv(n, **{**kwargs, "cycle": self.cycles})
            obs, _ = venv.reset(seed=self.seed, options=[{"cycle": c} for c in self.cycles])
            soc0 = venv.phys_state[:, core.SOC].copy()
            if reset is not None:
                reset()
            traces, returns = {k: np.zeros((horizon, n)) for k in TRACE_KEYS}, np.zeros(n)
            for t in range(horizon):
                obs, reward, _, _, info = venv.step(act(obs))
                returns += np.where(t < lengths, reward, 0.0)
                for k in TRACE_KEYS:
                    traces[k][t] = info[k]
            for i, (name, cyc) in enumerate(zip(self.cycle_names, self.cycles)):
                m = int(lengths[i])
                s = run_metrics({k: traces[k][:m, i] for k in TRACE_KEYS}, venv.config, float(soc0[i]), cyc.speed_mps,
                                0, m, venv.core.dt_s)
                results.append({"cycle": name, "scenario": scenario, "return_g": float(returns[i]),
                                **{k: s[k] for k in METRIC_KEYS}})
            venv.close()
        return results


def final_validation(run: Any) -> dict[str, Any]:
    """The final report of a run (a :class:`~hev_thermal_env.training.loop.TrainingRun`): ``best_model.zip`` and
    ``model.zip`` on ``eval.final_cycles`` (e.g. every ``validation_bus`` cycle, where training scored its checkpoints
    on a few) in every evaluation scenario, scored by the run's selection rule (:mod:`.selection`). Writes
    ``DIR/validation.csv`` (one row per model × cycle × scenario); returns the summary, also the ``result.validation``
    section of ``DIR/config.yaml``."""
    cfg, ev = run.config, run.config["eval"]
    evaluator = PolicyEvaluator(cfg["env"], ev["final_cycles"], ev["scenarios"], seed=int(cfg["seed"]))
    ref = run.references(evaluator.cycle_names)
    rows: list[list[Any]] = []
    models: dict[str, Any] = {}
    described: dict[str, str] = {}
    for name in ("best_model.zip", "model.zip"):
        if not (run.out / name).is_file():
            continue
        results = evaluator.run(load_policy(run.out / name).act)
        score = run.scorer.score(results, ref)
        for r, ratio in zip(results, score.ratios):
            r = {**r, "model": name, "reference_l_per_100km": ref[run_key(r["cycle"], r["scenario"])],
                 "fuel_ratio": ratio}
            rows.append([r[k] for k in VALIDATION_COLUMNS])
        described[name] = score.describe(run.scorer.short)
        models[name] = {"score": round(score.value, 6), "qualified": score.qualified, "violations": score.violations,
                        "mean_fuel_ratio": round(float(np.mean(score.ratios)), 6),
                        "max_abs_delta_soc": round(max(abs(r["delta_soc"]) for r in results), 6),
                        "mean_fuel_corrected_l_per_100km":
                            round(float(np.mean([r["fuel_corrected_l_per_100km"] for r in results])), 4)}
    write_csv(run.out / "validation.csv", VALIDATION_COLUMNS, rows)
    summary = {"selection": run.scorer.name, "rule": run.scorer.label, "cycles": list(ev["final_cycles"]),
               "runs": len(evaluator.cycle_names) * len(ev["scenarios"]), "scenarios": list(ev["scenarios"]),
               "models": models}
    cfg["result"]["validation"] = summary
    if run.verbose:
        parts = "; ".join(f"{name}: {text}, max |dSOC| {models[name]['max_abs_delta_soc']:.3f}"
                          for name, text in described.items())
        run.log(f"validation on {summary['runs']} runs ({', '.join(summary['cycles'])} × "
                f"{', '.join(summary['scenarios'])}): {parts}")
    return summary
