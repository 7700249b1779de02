"""Training of SB3 agents (PPO, SAC) on ``HevThermal-v0``: the library behind ``train.py``.

A run is described by one plain dict, its *config* (saved as ``DIR/config.yaml``), built by
:func:`build_config` from the algorithm's hyperparameter file (``agents/hyperparams/<algo>.yaml``),
overrides (``--hp key=value``) and the command-line settings. :func:`train` runs it, or continues
it (:func:`resume`), and writes an rl-baselines3-zoo-like run directory::

    DIR/model.zip, DIR/vecnormalize.pkl            final model and its observation/reward statistics
    DIR/best_model.zip, DIR/best_vecnormalize.pkl  best model on the evaluation cycles, with its statistics
    DIR/config.yaml, DIR/command.txt               the full config (incl. versions) and the command(s)
    DIR/checkpoints/ckpt_N_steps.zip (+ _vecnormalize.pkl, + _replay_buffer.pkl for SAC)
    DIR/evaluations.csv, DIR/training_curve.png    periodic deterministic evaluation, and its plot
    DIR/tb/                                        TensorBoard logs

Environment: by default the native batched vector env through its SB3 adapter
(:class:`hev_thermal_env.vector_env.Sb3VecEnv`, ``vec="native"``); ``"subproc"`` and ``"dummy"``
run SB3's ``SubprocVecEnv`` / ``DummyVecEnv`` over single ``HevThermal-v0`` envs. Observations and
rewards are normalised by ``VecNormalize``. The time spent inside the environment is measured
(:class:`TimedVecEnv`) and reported as a share of the training time.

Evaluation: every ``eval.freq`` env-steps the current policy drives each evaluation cycle
(default ``beijing`` and ``us06``, not trained on) in each evaluation scenario from its start,
deterministically, all cycles in one batched env; the observations are normalised with the
training statistics, which the evaluation does not update. The score is the mean episode return
(minus fuel-equivalent grams); the best model is kept with its statistics.

Interruption: SIGINT or SIGTERM stops training at the next step (the partial rollout is dropped),
saves a checkpoint and raises :class:`TrainingInterrupted`; checkpoints are written atomically
(statistics first, model last), so after a ``kill -9`` the latest complete checkpoint is intact.
Checkpoints and evaluations happen at the start of a rollout, when every step counted has been
trained on. :func:`resume` continues from the latest checkpoint (model, statistics, timesteps done;
for SAC the replay buffer) up to the original total.
"""

from __future__ import annotations

import ast
import contextlib
import copy
import csv
import datetime as _dt
import io
import math
import os
import pickle
import platform
import shlex
import signal
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hev_thermal_env.commands.io import read_yaml_mapping

HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
ALGORITHMS = ("ppo", "sac")
VEC_MODES = ("native", "subproc", "dummy")
DEFAULT_EVAL_CYCLES = ("beijing", "us06")

#: Keys of a hyperparameter file that describe the run rather than the algorithm's constructor.
RUN_KEYS = ("n_timesteps", "n_envs", "env", "normalize", "eval", "checkpoint_freq", "policy")

#: Settings of the environment a run trains on (the ``env`` section of the config).
ENV_KEYS = ("cycles", "scenario", "random_start", "preview_s", "preview_step_s", "thermal", "reward")

ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU",
               "silu": "SiLU"}

EVAL_COLUMNS = ("timesteps", "wall_s", "cycle", "scenario", "return_g", "fuel_corrected_l_per_100km", "delta_soc",
                "cutoff_s", "trace_miss_max_mps", "mean_return_g", "best")


class TrainingInterrupted(Exception):
    """Training stopped on a signal after saving a checkpoint (``exit_code`` 130 for SIGINT)."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


# --- algorithms and hyperparameters -----------------------------------------------------------------

def algorithm_class(algo: str):
    """The SB3 class of ``algo`` (``ppo`` or ``sac``)."""
    name = str(algo).lower()
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}; known algorithms: {', '.join(ALGORITHMS)}")
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "sac": sb3.SAC}[name]


def load_hyperparams(algo: str, path: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameter file of ``algo`` (``agents/hyperparams/<algo>.yaml`` unless ``path``) as a dict."""
    algorithm_class(algo)  # validates the name
    p = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo.lower()}.yaml"
    if not p.is_file():
        raise FileNotFoundError(f"hyperparameter file {p} not found")
    data = read_yaml_mapping(p)
    return data


def parse_value(text: str) -> Any:
    """A ``--hp`` value: YAML (``0.99``, ``[64, 64]``, ``{net_arch: [64, 64]}``, ``lin_3e-4``) or ``dict(k=v, ...)``."""
    s = text.strip()
    if s.startswith("dict(") and s.endswith(")"):
        try:
            call = ast.parse(s, mode="eval").body
            if not isinstance(call, ast.Call) or call.args:
                raise ValueError
            return {kw.arg: _literal(kw.value) for kw in call.keywords if kw.arg is not None}
        except (SyntaxError, ValueError):
            raise ValueError(f"cannot parse {text!r}: use dict(key=literal, ...) or YAML, "
                             f"e.g. {{net_arch: [64, 64]}}") from None
    try:
        return yaml.safe_load(s) if s else None
    except yaml.YAMLError as exc:
        raise ValueError(f"cannot parse {text!r} as YAML ({' '.join(str(exc).split())})") from None


def _literal(node: ast.AST) -> Any:
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
        return {kw.arg: _literal(kw.value) for kw in node.keywords}
    if isinstance(node, ast.Attribute):  # nn.Tanh, th.nn.ReLU -> "tanh", "relu"
        return node.attr.lower().replace("leakyrelu", "leaky_relu")
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_literal(e) for e in node.elts]
    if isinstance(node, ast.Dict):
        return {_literal(k): _literal(v) for k, v in zip(node.keys, node.values)}
    return ast.literal_eval(node)


def parse_overrides(items: Iterable[str]) -> dict[str, Any]:
    """``["gamma=0.99", "policy_kwargs.net_arch=[64,64]"]`` -> ``{"gamma": 0.99, "policy_kwargs.net_arch": [64, 64]}``.

    Dotted keys are resolved by :func:`apply_overrides`."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key or any(not part for part in key.split(".")):
            raise ValueError(f"--hp {item!r}: expected key=value (e.g. gamma=0.99 or policy_kwargs.net_arch=[64,64])")
        out[key] = parse_value(value)
    return out


def apply_overrides(hp: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """A deep copy of ``hp`` with dotted-key overrides applied (mappings are merged, not replaced)."""
    hp = copy.deepcopy(hp)
    for key, value in overrides.items():
        node = hp
        parts = key.split(".")
        for part in parts[:-1]:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        if isinstance(value, dict) and isinstance(node.get(parts[-1]), dict):
            node[parts[-1]] = {**node[parts[-1]], **value}
        else:
            node[parts[-1]] = value
    return hp


def schedule(value: Any) -> Any:
    """``"lin_3e-4"`` -> a linear decay from 3e-4 to 0 over training; numbers stay constants."""
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            initial = float(value[4:])
        except ValueError:
            raise ValueError(f"schedule {value!r}: expected lin_<number>, e.g. lin_3e-4") from None
        return LinearSchedule(initial)
    return value


class LinearSchedule:
    """``progress_remaining`` (1 -> 0) times the initial value; picklable (saved inside the model)."""

    def __init__(self, initial: float):
        self.initial = float(initial)

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.initial

    def __repr__(self) -> str:
        return f"lin_{self.initial:g}"


def algorithm_kwargs(algo: str, hp: dict[str, Any]) -> dict[str, Any]:
    """Constructor arguments for the SB3 class from the config's ``hyperparams``."""
    import torch

    kwargs = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    for key in ("learning_rate", "clip_range", "clip_range_vf"):
        if key in kwargs:
            kwargs[key] = schedule(kwargs[key])
    if "train_freq" in kwargs and isinstance(kwargs["train_freq"], list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    pk = dict(kwargs.get("policy_kwargs") or {})
    act = pk.get("activation_fn")
    if isinstance(act, str):
        name = ACTIVATIONS.get(act.lower())
        if name is None:
            raise ValueError(f"policy_kwargs.activation_fn {act!r}: expected one of {', '.join(ACTIVATIONS)}")
        pk["activation_fn"] = getattr(torch.nn, name)
    if pk:
        kwargs["policy_kwargs"] = pk
    return kwargs


# --- the run config ----------------------------------------------------------------------------------

def versions() -> dict[str, str]:
    import gymnasium
    import stable_baselines3
    import torch

    import hev_thermal_env

    return {"python": platform.python_version(), "numpy": str(np.__version__), "torch": str(torch.__version__),
            "stable_baselines3": str(stable_baselines3.__version__), "gymnasium": str(gymnasium.__version__),
            "hev_thermal_env": hev_thermal_env.__version__, "platform": platform.platform()}


def build_config(algo: str, *, hyperparams_file: str | Path | None = None, overrides: dict[str, Any] | None = None,
                 cycles: Sequence[str] | None = None, scenario: str | None = None, timesteps: int | None = None,
                 n_envs: int | None = None, seed: int = 0, vec: str = "native",
                 eval_cycles: Sequence[str] | None = None, eval_scenarios: Sequence[str] | None = None,
                 eval_freq: int | None = None, checkpoint_freq: int | None = None,
                 command: str | None = None) -> dict[str, Any]:
    """The complete config of a run (validated), from the hyperparameter file, overrides and settings."""
    algo = str(algo).lower()
    hp = apply_overrides(load_hyperparams(algo, hyperparams_file), overrides or {})
    env = dict(hp.pop("env", None) or {})
    ev = dict(hp.pop("eval", None) or {})
    normalize = hp.pop("normalize", None)
    total = hp.pop("n_timesteps", None)
    envs = hp.pop("n_envs", None)
    ckpt = hp.pop("checkpoint_freq", None)
    if cycles is not None:
        env["cycles"] = list(cycles)
    if scenario is not None:
        env["scenario"] = scenario
    env.setdefault("cycles", ["hwfet", "random_bus"])
    env.setdefault("scenario", "random")
    env.setdefault("random_start", True)
    env.setdefault("preview_s", 10)
    env.setdefault("preview_step_s", 2)
    env.setdefault("thermal", True)
    env.setdefault("reward", {})
    if eval_cycles is not None:
        ev["cycles"] = list(eval_cycles)
    if eval_scenarios is not None:
        ev["scenarios"] = list(eval_scenarios)
    if eval_freq is not None:
        ev["freq"] = eval_freq
    ev.setdefault("cycles", list(DEFAULT_EVAL_CYCLES))
    ev.setdefault("scenarios", ["paper"])
    ev.setdefault("freq", 100_000)
    hp.setdefault("policy", "MlpPolicy")
    if normalize is None or normalize is True:
        normalize = {}
    if normalize is not False:
        normalize = {"norm_obs": True, "norm_reward": True, "clip_obs": 10.0, "clip_reward": 10.0, **normalize}
    config = {
        "algo": algo,
        "seed": int(seed),
        "total_timesteps": int(timesteps if timesteps is not None else (total or 1_000_000)),
        "n_envs": int(n_envs if n_envs is not None else (envs or 1)),
        "vec": vec,
        "env": env,
        "normalize": normalize,
        "hyperparams": hp,
        "eval": ev,
        "checkpoint_freq": int(checkpoint_freq if checkpoint_freq is not None else (ckpt or 500_000)),
        "command": command,
        "created": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "versions": versions(),
    }
    validate_config(config)
    return config


def validate_config(config: dict[str, Any]) -> None:
    """Fail before any work, with one-line messages, on unknown names and impossible numbers."""
    from hev_thermal_env.cycles import load_cycle
    from hev_thermal_env.env import RANDOM_BUS, observation_names
    from hev_thermal_env.reward import RewardParams
    from hev_thermal_env.scenarios import get_scenario

    algorithm_class(config["algo"])
    if config["vec"] not in VEC_MODES:
        raise ValueError(f"unknown --vec {config['vec']!r}; choose one of {', '.join(VEC_MODES)}")
    env = config["env"]
    unknown = sorted(set(env) - set(ENV_KEYS) - {"observation_size", "observation_names"})
    if unknown:
        raise ValueError(f"unknown env setting(s) {unknown}; known: {', '.join(ENV_KEYS)}")
    cycles = env["cycles"] if isinstance(env["cycles"], list) else [env["cycles"]]
    if not cycles:
        raise ValueError("no training cycles given")
    for c in cycles:
        if str(c).strip().lower() != RANDOM_BUS:
            load_cycle(c)
    env["cycles"] = [str(c) for c in cycles]
    get_scenario(env["scenario"])
    RewardParams.from_dict(dict(env.get("reward") or {}), where="env.reward")
    names = observation_names(int(env["preview_s"]), int(env["preview_step_s"]))
    env["observation_size"] = len(names)
    env["observation_names"] = list(names)
    ev = config["eval"]
    for c in ev["cycles"]:
        load_cycle(c)
    for s in ev["scenarios"]:
        get_scenario(s)
    for key, value, least in (("total_timesteps", config["total_timesteps"], 1), ("n_envs", config["n_envs"], 1),
                              ("checkpoint_freq", config["checkpoint_freq"], 1), ("eval.freq", ev["freq"], 0)):
        if int(value) < least:
            raise ValueError(f"{key} must be at least {least}, got {value}")
    algorithm_kwargs(config["algo"], config["hyperparams"])


def save_yaml(path: Path, data: Any) -> None:
    atomic_write_bytes(path, yaml.safe_dump(data, sort_keys=False, allow_unicode=True).encode())


def load_run_config(run_dir: str | Path) -> dict[str, Any]:
    p = Path(run_dir) / "config.yaml"
    if not Path(run_dir).is_dir():
        raise FileNotFoundError(f"run directory {run_dir} not found")
    if not p.is_file():
        raise FileNotFoundError(f"{p} not found: {run_dir} is not a train.py run directory")
    data = read_yaml_mapping(p)
    if "algo" not in data or "env" not in data:
        raise ValueError(f"{p}: not a train.py config")
    return data


# --- files ------------------------------------------------------------------------------------------

def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` so that ``path`` is either absent/old or complete (temporary file + rename)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp creates 0600; give the file the usual permissions
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def model_bytes(model, exclude_optimizer_state: bool = False) -> bytes:
    """The SB3 zip of ``model`` as bytes (optionally with a fresh optimizer state: a smaller file)."""
    buf = io.BytesIO()
    if exclude_optimizer_state:
        policy = model.policy
        saved = policy.optimizer
        policy.optimizer = type(saved)(policy.parameters(), **saved.defaults)
        try:
            model.save(buf)
        finally:
            policy.optimizer = saved
    else:
        model.save(buf)
    return buf.getvalue()


def save_model_and_stats(model, stats, model_path: Path, stats_path: Path) -> None:
    """Statistics first, the model last, each atomically: a present model zip means a complete pair."""
    if stats is not None:
        atomic_write_bytes(stats_path, pickle.dumps(stats))
    atomic_write_bytes(model_path, model_bytes(model))


# --- environments -----------------------------------------------------------------------------------

def env_kwargs(env_cfg: dict[str, Any], *, for_eval: bool = False) -> dict[str, Any]:
    """Keyword arguments of ``HevThermalEnv`` / ``HevThermalVectorEnv`` for the config's env section."""
    return {"cycle": list(env_cfg["cycles"]), "scenario": env_cfg["scenario"],
            "random_start": False if for_eval else bool(env_cfg.get("random_start", True)),
            "preview_s": int(env_cfg["preview_s"]), "preview_step_s": int(env_cfg["preview_step_s"]),
            "thermal": bool(env_cfg.get("thermal", True)), "reward": dict(env_cfg.get("reward") or {})}


def _build_vec_env_wrapper():
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class TimedVecEnv(VecEnvWrapper):
        """Measures the wall time spent in the wrapped env's ``reset`` and ``step`` (``seconds``)."""

        def __init__(self, venv):
            super().__init__(venv)
            self.seconds = 0.0
            self.steps = 0

        def reset(self):
            t = time.perf_counter()
            obs = self.venv.reset()
            self.seconds += time.perf_counter() - t
            return obs

        def step_async(self, actions):
            t = time.perf_counter()
            self.venv.step_async(actions)
            self.seconds += time.perf_counter() - t

        def step_wait(self):
            t = time.perf_counter()
            result = self.venv.step_wait()
            self.seconds += time.perf_counter() - t
            self.steps += self.num_envs
            return result

    return TimedVecEnv


_TIMED: type | None = None


def timed_vec_env(venv):
    global _TIMED
    if _TIMED is None:
        _TIMED = _build_vec_env_wrapper()
    return _TIMED(venv)


def _make_single_env(kwargs: dict[str, Any]) -> Callable[[], Any]:
    def make():
        from hev_thermal_env.env import HevThermalEnv

        return HevThermalEnv(**kwargs)

    return make


def make_vec_env(config: dict[str, Any]):
    """The raw training VecEnv of the config (no normalisation), timed (:class:`TimedVecEnv`)."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    kwargs = env_kwargs(config["env"])
    n = int(config["n_envs"])
    if config["vec"] == "native":
        from hev_thermal_env.vector_env import Sb3VecEnv

        raw = Sb3VecEnv(n, info_keys=(), **kwargs)
    elif config["vec"] == "subproc":
        raw = SubprocVecEnv([_make_single_env(kwargs) for _ in range(n)])
    else:
        raw = DummyVecEnv([_make_single_env(kwargs) for _ in range(n)])
    timed = timed_vec_env(raw)
    return VecMonitor(timed), timed


def wrap_normalize(venv, config: dict[str, Any], stats_path: Path | None = None):
    """``VecNormalize`` over ``venv`` (fresh, or with the statistics saved at ``stats_path``)."""
    from stable_baselines3.common.vec_env import VecNormalize

    norm = config["normalize"]
    if norm is False:
        return venv
    if stats_path is not None:
        vn = VecNormalize.load(str(stats_path), venv)
        vn.training = True
        return vn
    gamma = float(config["hyperparams"].get("gamma", 0.99))
    return VecNormalize(venv, gamma=gamma, **norm)


# --- evaluation -------------------------------------------------------------------------------------

class PolicyEvaluator:
    """Deterministic runs of a policy over fixed cycles × scenarios, every cycle of a scenario in one batch.

    Each (cycle, scenario) runs from the cycle's start with the scenario's conditions (random
    scenarios draw them from ``seed``), in a :class:`~hev_thermal_env.vector_env.HevThermalVectorEnv`
    built with the run's env settings (preview, reward, thermal model). The metrics are those of
    :func:`agents.evaluation.run_strategy` (:func:`hev_thermal_env.physics.simulate.summarize`).
    """

    def __init__(self, env_cfg: dict[str, Any], cycles: Sequence[str], scenarios: Sequence[str], seed: int = 0):
        from hev_thermal_env.cycles import load_cycle

        self.env_cfg = env_cfg
        self.cycles = [load_cycle(c) for c in cycles]
        self.cycle_names = list(cycles)
        self.scenarios = list(scenarios)
        self.seed = int(seed)

    def run(self, act: Callable[[np.ndarray], np.ndarray]) -> list[dict[str, Any]]:
        """Drive every (cycle, scenario) with ``act(raw_obs [n, dim]) -> actions [n, 1]``; one result per run."""
        from hev_thermal_env.physics import core as C
        from hev_thermal_env.physics.simulate import summarize
        from hev_thermal_env.vector_env import HevThermalVectorEnv

        results = []
        keys = ("fuel_g", "battery_chem_power_w", "missed_wheel_energy_j", "soc", "motor_temp_c", "heat_index",
                "motor_cutoff", "trace_miss_mps", "engine_on")
        for scenario in self.scenarios:
            kwargs = env_kwargs({**self.env_cfg, "scenario": scenario}, for_eval=True)
            kwargs["cycle"] = self.cycles
            n = len(self.cycles)
            venv = HevThermalVectorEnv(n, **kwargs)
            obs, _ = venv.reset(seed=self.seed, options=[{"cycle": c} for c in self.cycles])
            soc0 = venv.phys_state[:, C.SOC].copy()
            lengths = np.array([c.n_steps for c in self.cycles])
            horizon = int(lengths.max())
            traces = {k: np.zeros((horizon, n)) for k in keys}
            returns = np.zeros(n)
            for t in range(horizon):
                obs, reward, _, _, info = venv.step(act(obs))
                live = t < lengths
                returns += np.where(live, reward, 0.0)
                for k in keys:
                    traces[k][t] = info[k]
            for i, (name, cyc) in enumerate(zip(self.cycle_names, self.cycles)):
                m = int(lengths[i])
                trace = {k: traces[k][:m, i] for k in keys}
                v = np.asarray(cyc.speed_mps, dtype=np.float64)
                distance = float(np.sum(0.5 * (v[:m] + v[1:m + 1])))
                s = summarize(trace, venv.config, float(soc0[i]), distance, venv.core.dt_s)
                results.append({"cycle": name, "scenario": scenario, "return_g": float(returns[i]),
                                "fuel_corrected_l_per_100km": s["fuel_corrected_l_per_100km"],
                                "delta_soc": s["soc_final"] - s["soc_initial"], "cutoff_s": s["cutoff_s"],
                                "trace_miss_max_mps": s["trace_miss_max_mps"]})
            venv.close()
        return results


def model_actor(model, stats) -> Callable[[np.ndarray], np.ndarray]:
    """``act(raw_obs) -> u [n, 1]`` of an SB3 model with (read-only) normalisation statistics."""

    def act(obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float32)
        if stats is not None:
            o = stats.normalize_obs(o)
        actions, _ = model.policy.predict(o, deterministic=True)
        return np.asarray(actions, dtype=np.float32).reshape(-1, 1)

    return act


def read_evaluations(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("timesteps",):
            r[k] = int(float(r[k]))
        for k in ("wall_s", "return_g", "fuel_corrected_l_per_100km", "delta_soc", "cutoff_s", "trace_miss_max_mps",
                  "mean_return_g"):
            r[k] = float(r[k])
        r["best"] = str(r["best"]).lower() in ("1", "true")
    return rows


def write_evaluations(path: Path, rows: list[dict[str, Any]]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=EVAL_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (int(r[k]) if k == "best" else r[k]) for k in EVAL_COLUMNS})
    atomic_write_bytes(path, buf.getvalue().encode())


# --- callbacks --------------------------------------------------------------------------------------

def _callbacks():
    from stable_baselines3.common.callbacks import BaseCallback

    class RunCallback(BaseCallback):
        """Checkpoints, evaluation with best-model keeping, and stopping on a signal, in one callback.

        Checkpoints and evaluations happen at the start of a rollout, once ``model.num_timesteps``
        has crossed their next multiple of the frequency (in env-steps, so they hold across resumes):
        then every step counted has been trained on. A stop discards the partial rollout and sets the
        count back to its start, so a resumed run ends where an uninterrupted one would.
        """

        def __init__(self, run: TrainingRun):
            super().__init__()
            self.run = run
            self.stop_signal: int | None = None
            self.rollout_start = 0

        def _init_callback(self) -> None:
            r = self.run
            self.rollout_start = int(self.model.num_timesteps)
            self.next_ckpt = _next_multiple(self.model.num_timesteps, r.checkpoint_freq)
            self.next_eval = _next_multiple(self.model.num_timesteps, r.eval_freq) if r.eval_freq else math.inf

        def _on_rollout_start(self) -> None:
            n = int(self.model.num_timesteps)
            self.rollout_start = n
            if n >= self.next_eval:
                self.run.evaluate(self.model, self.logger)
                self.next_eval = _next_multiple(n, self.run.eval_freq)
            if n >= self.next_ckpt:
                self.run.checkpoint(self.model)
                self.next_ckpt = _next_multiple(n, self.run.checkpoint_freq)

        def _on_step(self) -> bool:
            if self.stop_signal is not None:
                self.model.num_timesteps = self.rollout_start
                return False
            return True

    return RunCallback


def _next_multiple(n: int, freq: int) -> int:
    return (int(n) // int(freq) + 1) * int(freq)


# --- the training run -------------------------------------------------------------------------------

class TrainingRun:
    """One training session of a run directory: builds env and model, trains, saves (see :func:`train`)."""

    def __init__(self, config: dict[str, Any], out_dir: Path, *, progress: bool = True, verbose: int = 1,
                 log: Callable[[str], None] | None = None):
        self.config = config
        self.out = Path(out_dir)
        self.progress = progress
        self.verbose = verbose
        self.log = log or (lambda msg: print(msg, flush=True))
        self.checkpoint_freq = int(config["checkpoint_freq"])
        self.eval_freq = int(config["eval"]["freq"])
        self.eval_rows = read_evaluations(self.out / "evaluations.csv")
        self.best_score = max((r["mean_return_g"] for r in self.eval_rows), default=-math.inf)
        self.eval_seconds = 0.0
        self.session_start = time.perf_counter()
        self.wall_before = float((config.get("result") or {}).get("wall_s", 0.0))
        self.evaluator = None
        if self.eval_freq and config["eval"]["cycles"]:
            self.evaluator = PolicyEvaluator(config["env"], config["eval"]["cycles"], config["eval"]["scenarios"],
                                             seed=int(config["seed"]))

    # -- pieces ----------------------------------------------------------------------------------------

    @property
    def ckpt_dir(self) -> Path:
        return self.out / "checkpoints"

    def stats_of(self, model):
        from stable_baselines3.common.vec_env import VecNormalize

        env = model.get_env()
        while env is not None:
            if isinstance(env, VecNormalize):
                return env
            env = getattr(env, "venv", None)
        return None

    def checkpoint(self, model) -> Path:
        n = int(model.num_timesteps)
        zip_path = self.ckpt_dir / f"ckpt_{n}_steps.zip"
        if self.config["algo"] == "sac" and self.config["hyperparams"].get("save_replay_buffer", True):
            buf = io.BytesIO()
            model.save_replay_buffer(buf)
            atomic_write_bytes(self.ckpt_dir / f"ckpt_{n}_steps_replay_buffer.pkl", buf.getvalue())
            for old in self.ckpt_dir.glob("ckpt_*_steps_replay_buffer.pkl"):  # keep only the newest buffer
                if old.name != f"ckpt_{n}_steps_replay_buffer.pkl":
                    old.unlink(missing_ok=True)
        save_model_and_stats(model, self.stats_of(model), zip_path,
                             self.ckpt_dir / f"ckpt_{n}_steps_vecnormalize.pkl")
        return zip_path

    def evaluate(self, model, logger=None) -> list[dict[str, Any]]:
        if self.evaluator is None:
            return []
        t = time.perf_counter()
        stats = self.stats_of(model)
        results = self.evaluator.run(model_actor(model, stats))
        self.eval_seconds += time.perf_counter() - t
        score = float(np.mean([r["return_g"] for r in results]))
        best = score > self.best_score
        n = int(model.num_timesteps)
        wall = self.wall_before + time.perf_counter() - self.session_start
        for r in results:
            self.eval_rows.append({"timesteps": n, "wall_s": round(wall, 2), **r, "mean_return_g": score, "best": best})
        write_evaluations(self.out / "evaluations.csv", self.eval_rows)
        if best:
            self.best_score = score
            save_model_and_stats(model, stats, self.out / "best_model.zip", self.out / "best_vecnormalize.pkl")
        if logger is not None:
            logger.record("eval/mean_return_g", score)
            for r in results:
                tag = f"{r['cycle']}_{r['scenario']}"
                logger.record(f"eval/return_g_{tag}", r["return_g"])
                logger.record(f"eval/fuel_corrected_l_per_100km_{tag}", r["fuel_corrected_l_per_100km"])
                logger.record(f"eval/delta_soc_{tag}", r["delta_soc"])
                logger.record(f"eval/cutoff_s_{tag}", r["cutoff_s"])
        if self.verbose:
            parts = ", ".join(f"{r['cycle']}/{r['scenario']} {r['fuel_corrected_l_per_100km']:.2f} L/100km "
                              f"dSOC {r['delta_soc']:+.3f}" for r in results)
            self.log(f"eval @ {n}: mean return {score:.1f} g{' (new best)' if best else ''}; {parts}")
        return results

    def dp_reference(self) -> None:
        """Corrected fuel of ``dp`` on the evaluation cycles (fixed scenarios), for the training curve."""
        if not self.config["eval"].get("dp_reference", True):
            return
        from hev_thermal_env.scenarios import get_scenario

        from . import get_strategy
        from .evaluation import run_strategy

        ref = {}
        try:
            for scenario in self.config["eval"]["scenarios"]:
                if get_scenario(scenario).randomized:
                    continue
                for cycle in self.config["eval"]["cycles"]:
                    res = run_strategy(get_strategy("dp", on_infeasible="closest"), cycle, scenario)
                    ref[f"{cycle} / {scenario}"] = round(float(res.summary["fuel_corrected_l_per_100km"]), 4)
        except Exception as exc:  # noqa: BLE001 - the reference only decorates the plot
            self.log(f"note: no DP reference for the training curve ({type(exc).__name__}: {exc})")
            return
        self.config.setdefault("result", {})["dp_reference_l_per_100km"] = ref
        save_yaml(self.out / "config.yaml", self.config)

    def make_model(self, venv, resume_from: Path | None):
        import torch
        from stable_baselines3.common.utils import set_random_seed

        cfg = self.config
        cls = algorithm_class(cfg["algo"])
        seed = int(cfg["seed"])
        tb = str(self.out / "tb")
        if resume_from is None:
            set_random_seed(seed)
            kwargs = algorithm_kwargs(cfg["algo"], cfg["hyperparams"])
            policy = kwargs.pop("policy", "MlpPolicy")
            return cls(policy, venv, seed=seed, tensorboard_log=tb, verbose=0, device="cpu", **kwargs)
        with warnings_suppressed():
            model = cls.load(resume_from, env=venv, device="cpu")
        model.tensorboard_log = tb
        # a fresh but reproducible stream for the continued session
        model.set_random_seed(seed + int(model.num_timesteps))
        torch.manual_seed(seed + int(model.num_timesteps))
        replay = resume_from.with_name(resume_from.stem + "_replay_buffer.pkl")
        if cfg["algo"] == "sac" and replay.is_file():
            model.load_replay_buffer(replay)
        return model

    # -- the session -----------------------------------------------------------------------------------

    def execute(self, resume_from: tuple[int, Path, Path] | None = None) -> dict[str, Any]:
        cfg = self.config
        self.out.mkdir(parents=True, exist_ok=True)
        self.ckpt_dir.mkdir(exist_ok=True)
        if resume_from is not None and cfg["normalize"] is not False and not resume_from[2].is_file():
            raise FileNotFoundError(f"{resume_from[2]} not found: the checkpoint has no normalisation statistics")
        if resume_from is None and self.evaluator is not None:
            self.dp_reference()
        raw, timed = make_vec_env(cfg)
        venv = wrap_normalize(raw, cfg, resume_from[2] if resume_from and cfg["normalize"] is not False else None)
        model = self.make_model(venv, resume_from[1] if resume_from else None)
        venv.seed(int(cfg["seed"]) + int(model.num_timesteps))
        done_before = int(model.num_timesteps)
        remaining = int(cfg["total_timesteps"]) - done_before
        callback = _callbacks()(self)
        interrupted: int | None = None
        t0 = time.perf_counter()
        if remaining > 0:
            with stop_on_signals(callback):
                model.learn(remaining, callback=callback, reset_num_timesteps=resume_from is None,
                            tb_log_name=cfg["algo"].upper(), progress_bar=self.progress)
            interrupted = callback.stop_signal
        train_s = time.perf_counter() - t0
        steps = int(model.num_timesteps) - done_before
        result = {
            "timesteps_done": int(model.num_timesteps),
            "session_wall_s": round(train_s, 2),
            "session_timesteps": steps,
            "steps_per_s": round(steps / train_s, 1) if train_s > 0 else None,
            "env_s": round(timed.seconds, 2),
            "eval_s": round(self.eval_seconds, 2),
            # share of the training loop (evaluation excluded) spent stepping the env
            "env_share": round(timed.seconds / (train_s - self.eval_seconds), 4) if train_s > self.eval_seconds
            else None,
        }
        if interrupted is not None:
            path = self.checkpoint(model)
            self.record_session(result, finished=False)
            raw.close()
            name = signal.Signals(interrupted).name
            raise TrainingInterrupted(f"{name}: training stopped at {model.num_timesteps} of "
                                      f"{cfg['total_timesteps']} timesteps; checkpoint {path}; continue with "
                                      f"python train.py --resume {self.out}", 128 + int(interrupted))
        evaluated = bool(self.eval_rows) and self.eval_rows[-1]["timesteps"] == model.num_timesteps
        if self.evaluator is not None and not evaluated:
            self.evaluate(model, model.logger if steps else None)
        save_model_and_stats(model, self.stats_of(model), self.out / "model.zip", self.out / "vecnormalize.pkl")
        if not (self.out / "best_model.zip").is_file():
            save_model_and_stats(model, self.stats_of(model), self.out / "best_model.zip",
                                 self.out / "best_vecnormalize.pkl")
        self.checkpoint(model)
        self.record_session(result, finished=True)
        raw.close()
        if self.eval_rows:
            plot_training_curve(self.out, (cfg.get("result") or {}).get("dp_reference_l_per_100km"))
        return self.config["result"]

    def record_session(self, session: dict[str, Any], finished: bool) -> None:
        cfg = self.config
        res = dict(cfg.get("result") or {})
        sessions = list(res.get("sessions") or [])
        sessions.append(session)
        wall = sum(s["session_wall_s"] for s in sessions)
        res.update(finished=finished, timesteps_done=session["timesteps_done"], wall_s=round(wall, 2),
                   sessions=sessions, env_share=session["env_share"], steps_per_s=session["steps_per_s"])
        if self.eval_rows:
            best = max(self.eval_rows, key=lambda r: r["mean_return_g"])
            res["best_eval"] = {"timesteps": best["timesteps"], "mean_return_g": best["mean_return_g"]}
        cfg["result"] = res
        save_yaml(self.out / "config.yaml", cfg)


@contextlib.contextmanager
def warnings_suppressed():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


@contextlib.contextmanager
def stop_on_signals(callback):
    """SIGINT/SIGTERM ask ``callback`` to stop training at the next step; a second SIGINT stops at once."""
    if threading_is_main():
        def handler(signum, frame):
            if callback.stop_signal is not None and signum == signal.SIGINT:
                raise KeyboardInterrupt
            callback.stop_signal = signum

        old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for s, h in old.items():
                signal.signal(s, h)
    else:
        yield


def threading_is_main() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def train(config: dict[str, Any], out_dir: str | Path, *, progress: bool = True, verbose: int = 1,
          overwrite: bool = False, log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Train a new run into ``out_dir``; returns the ``result`` section of its config.

    ``out_dir`` must not hold a run already (unless ``overwrite``): continue one with :func:`resume`.
    Raises :class:`TrainingInterrupted` after saving a checkpoint when stopped by a signal.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out}: exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        if (out / "config.yaml").is_file():
            raise ValueError(f"--out {out} already holds a run; continue it with --resume {out} or choose "
                             f"another directory")
        raise ValueError(f"--out {out} is not empty; choose an empty or new directory")
    _limit_threads()
    out.mkdir(parents=True, exist_ok=True)
    save_yaml(out / "config.yaml", config)
    _append_command(out, config.get("command"))
    return TrainingRun(config, out, progress=progress, verbose=verbose, log=log).execute()


def resume(run_dir: str | Path, *, progress: bool = True, verbose: int = 1, command: str | None = None,
           log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Continue the run in ``run_dir`` from its latest complete checkpoint up to its total timesteps."""
    from .ppo import checkpoint_files

    out = Path(run_dir)
    config = load_run_config(out)
    validate_config(config)
    log = log or (lambda msg: print(msg, flush=True))
    if (config.get("result") or {}).get("finished") and (out / "model.zip").is_file():
        log(f"{out}: already finished ({config['result']['timesteps_done']} timesteps); nothing to do")
        return config["result"]
    _limit_threads()
    _append_command(out, command)
    ckpts = checkpoint_files(out)
    start = ckpts[-1] if ckpts else None
    if start is None:
        log(f"{out}: no checkpoint yet; starting the run over")
    else:
        log(f"{out}: resuming from {start[1].name} ({start[0]} of {config['total_timesteps']} timesteps)")
    return TrainingRun(config, out, progress=progress, verbose=verbose, log=log).execute(resume_from=start)


def _append_command(out: Path, command: str | None) -> None:
    if command:
        with open(out / "command.txt", "a") as fh:
            fh.write(command.rstrip("\n") + "\n")


def _limit_threads() -> None:
    """Torch on one thread (``HEV_TORCH_THREADS`` to change): with these small MLPs two threads gained
    only ~7 % here (35k vs 33k env-steps/s on 2 cores), and one leaves a core to other jobs."""
    import torch

    torch.set_num_threads(int(os.environ.get("HEV_TORCH_THREADS", "1")))


def command_line(argv: Sequence[str] | None = None) -> str:
    argv = list(sys.argv if argv is None else argv)
    return "python " + " ".join(shlex.quote(a) for a in argv)


# --- outputs ----------------------------------------------------------------------------------------

def plot_training_curve(run_dir: str | Path, dp_reference: dict[str, float] | None = None) -> Path:
    """``DIR/training_curve.png``: per evaluation cycle and scenario, the episode return (training
    reward) and the corrected fuel (with DP's as a dashed line when known) against timesteps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(run_dir)
    rows = read_evaluations(out / "evaluations.csv")
    series: dict[str, dict[int, dict[str, Any]]] = {}
    for r in rows:  # a resumed run may evaluate the same step twice: the later row wins
        series.setdefault(f"{r['cycle']} / {r['scenario']}", {})[r["timesteps"]] = r
    n = max(len(series), 1)
    fig, axes = plt.subplots(2, n, figsize=(4.2 * n, 6), sharex=True, squeeze=False)
    for j, (label, by_step) in enumerate(series.items()):
        steps = sorted(by_step)
        best = [s for s in steps if by_step[s]["best"]]
        axes[0, j].plot(steps, [by_step[s]["return_g"] for s in steps], marker=".")
        axes[0, j].set_title(label, fontsize=10)
        axes[1, j].plot(steps, [by_step[s]["fuel_corrected_l_per_100km"] for s in steps], marker=".", label="policy")
        axes[1, j].plot(best, [by_step[s]["fuel_corrected_l_per_100km"] for s in best], "o", mfc="none", ms=8,
                        label="new best (mean return)")
        if dp_reference and label in dp_reference:
            axes[1, j].axhline(dp_reference[label], color="k", ls="--", lw=1, label="DP")
        axes[1, j].set_xlabel("timesteps")
        axes[1, j].legend(fontsize=8)
    axes[0, 0].set_ylabel("episode return (training reward, g)")
    axes[1, 0].set_ylabel("corrected fuel (L/100 km)")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    cfg = load_run_config(out)
    fig.suptitle(f"{cfg['algo'].upper()} seed {cfg['seed']}: deterministic evaluation on cycles not trained on",
                 fontsize=10)
    fig.tight_layout()
    path = out / "training_curve.png"
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return path


def export_policy(run: str | Path, out_dir: str | Path, readme: str | None = None) -> Path:
    """Copy a trained policy into ``out_dir`` as a small package: ``model.zip`` (without the optimizer's
    state), ``vecnormalize.pkl`` and ``config.yaml`` (and ``README.md`` if given)."""
    from .ppo import find_run_config, load_obs_normalizer, load_sb3_model, resolve_model_path, stats_path_for

    model_path = resolve_model_path(run)
    config = find_run_config(model_path)
    if config is None:
        raise FileNotFoundError(f"no config.yaml next to {model_path}: export needs a train.py run")
    model = load_sb3_model(model_path, config["algo"])
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if config["normalize"] is not False:
        stats_path = stats_path_for(model_path)
        load_obs_normalizer(stats_path)  # checks it
        atomic_write_bytes(out / "vecnormalize.pkl", stats_path.read_bytes())
    atomic_write_bytes(out / "model.zip", model_bytes(model, exclude_optimizer_state=True))
    config = dict(config)
    config["exported_from"] = {"model": model_path.name, "timesteps": int(model.num_timesteps)}
    save_yaml(out / "config.yaml", config)
    if readme is not None:
        atomic_write_bytes(out / "README.md", readme.encode())
    return out
