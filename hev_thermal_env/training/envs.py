"""The training environments: the native vector env of a run config through its SB3 adapter
(:class:`~hev_thermal_env.wrappers.sb3.Sb3VecEnv`), timed (:class:`TimedVecEnv`: the env's share of
training is reported), for a constrained algorithm with the safety cost priced in (:mod:`.lagrangian`), and its
``VecNormalize``."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor, VecNormalize

from hev_thermal_env.wrappers.sb3 import Sb3VecEnv

from .lagrangian import LagrangianVecEnv, make_lagrangian


def env_kwargs(env_cfg: dict[str, Any], *, for_eval: bool = False) -> dict[str, Any]:
    """Keyword arguments of ``HevThermalEnv`` / ``HevThermalVectorEnv`` for the config's env section."""
    return {"cycle": list(env_cfg["cycles"]), "scenario": env_cfg["scenario"],
            "random_start": False if for_eval else bool(env_cfg.get("random_start", True)),
            "preview_s": int(env_cfg["preview_s"]), "preview_step_s": int(env_cfg["preview_step_s"]),
            "thermal": bool(env_cfg.get("thermal", True)), "reward": dict(env_cfg.get("reward") or {}),
            "soc_offset": 0.0 if for_eval else float(env_cfg.get("soc_offset", 0.0))}


class TimedVecEnv(VecEnvWrapper):
    """Measures the wall time spent in the wrapped env's ``reset`` and ``step`` (``seconds``)."""

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
        return make_lagrangian(monitored, config, float(sb3_env.venv.core.dt_s)), timed
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
    gamma = float(config["hyperparams"].get("gamma", 0.99))
    return VecNormalize(venv, gamma=gamma, **norm)
