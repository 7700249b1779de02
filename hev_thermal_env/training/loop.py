"""Training sessions: :func:`train` a new run into a directory, :func:`resume` an interrupted one (docs/training.md).

A new run creates its directory only once the config, the environment and the model are built: a run that cannot start
leaves nothing behind. Checkpoints are atomic; :func:`resume` continues from the latest (model, statistics, timesteps
done; for SAC the replay buffer) up to the original total. SIGINT or SIGTERM stops at the next step (the partial rollout
dropped), saves a checkpoint and raises :class:`TrainingInterrupted`; a second SIGINT stops at once
(``KeyboardInterrupt``).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import signal
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.utils import set_random_seed

from hev_thermal_env.agents.policy_files import (
    CHECKPOINTS,
    OFF_POLICY,
    LoadedPolicy,
    checkpoint_files,
    checkpoint_paths,
    custom_objects,
)
from hev_thermal_env.io import atomic_write_bytes, check_writable_dir

from .artifacts import check_new_dir, read_evaluations, save_model_and_stats, write_csv, write_evaluations
from .config import load_run_config, save_run_config, validate_config
from .curves import plot_training_curve
from .envs import PolicyEvaluator, env_kwargs, final_validation, make_vec_env, wrap_normalize
from .hyperparams import algorithm_class, algorithm_kwargs
from .imitation import imitate, resumed_refit
from .lagrangian import LagrangeMultiplier, LagrangianVecEnv, load_multiplier, save_multiplier
from .selection import compute_references, get_scorer, is_better


class TrainingInterrupted(KeyboardInterrupt):
    """Training stopped on a signal after saving a checkpoint (``exit_code`` 130 for SIGINT, 143 for SIGTERM).

    A ``KeyboardInterrupt``, like the Ctrl-C it comes from: ``train.py`` reports it in one line."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


class RunCallback(BaseCallback):
    """Checkpoints, evaluation with best-model keeping, and stopping on a signal, in one callback of a
    :class:`TrainingRun`.

    Checkpoints and evaluations happen at the start of a rollout, once ``model.num_timesteps`` has crossed their next
    multiple of the frequency (in env-steps, so they hold across resumes): then every step counted has been trained
    on. A stop discards the partial rollout and sets the count back to its start, so a resumed run ends where an
    uninterrupted one would."""

    def __init__(self, run: TrainingRun):
        super().__init__()
        self.run = run
        self.stop_signal: int | None = None
        self.rollout_start = 0

    def _init_callback(self) -> None:
        n, r = int(self.model.num_timesteps), self.run
        self.rollout_start, self.next_ckpt = n, _next_multiple(n, r.checkpoint_freq)
        self.next_eval = _next_multiple(n, r.eval_freq) if r.eval_freq else math.inf

    def _on_rollout_start(self) -> None:
        n = self.rollout_start = int(self.model.num_timesteps)
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


def _next_multiple(n: int, freq: int) -> int:
    return (int(n) // int(freq) + 1) * int(freq)


@contextlib.contextmanager
def stop_on_signals(callback: RunCallback):
    """SIGINT/SIGTERM ask ``callback`` to stop training at the next step; a second SIGINT stops at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

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


class TrainingRun:
    """One training session of a run directory: :meth:`prepare` builds the env and the model, :meth:`execute`
    trains and saves (see :func:`train`)."""

    def __init__(self, config: dict[str, Any], out_dir: Path, *, progress: bool = True, verbose: int = 1,
                 log: Callable[[str], None] | None = None):
        self.config, self.out, self.progress, self.verbose = config, Path(out_dir), progress, verbose
        self.log = log or _print
        self.checkpoint_freq, self.eval_freq = int(config["checkpoint_freq"]), int(config["eval"]["freq"])
        self.eval_rows = read_evaluations(self.out / "evaluations.csv")
        self.scorer = get_scorer(config["eval"]["selection"])
        self.best_score = min((r["score"] for r in self.eval_rows if np.isfinite(r["score"])), default=None)
        self.eval_seconds, self.session_start = 0.0, time.perf_counter()
        self.wall_before = float((config.get("result") or {}).get("wall_s", 0.0))
        self.evaluator = None
        if self.eval_freq and config["eval"]["cycles"]:
            self.evaluator = PolicyEvaluator(config["env"], config["eval"]["cycles"], config["eval"]["scenarios"],
                                             seed=int(config["seed"]))

    @property
    def multiplier(self) -> LagrangeMultiplier | None:
        """A constrained run's Lagrange multiplier (None otherwise)."""
        raw = getattr(self, "raw", None)
        return raw.multiplier if isinstance(raw, LagrangianVecEnv) else None

    def checkpoint(self, model) -> Path:
        n = int(model.num_timesteps)
        zip_path, stats_path, replay_path = checkpoint_paths(self.out, n)
        if self.multiplier is not None:
            save_multiplier(self.multiplier, zip_path)
        if self.config["algo"] in OFF_POLICY:
            buf = io.BytesIO()
            model.save_replay_buffer(buf)
            atomic_write_bytes(replay_path, buf.getvalue())
            for old in (self.out / CHECKPOINTS).glob("ckpt_*_steps_replay_buffer.pkl"):  # keep only the newest buffer
                if old != replay_path:
                    old.unlink(missing_ok=True)
        save_model_and_stats(model, model.get_vec_normalize_env(), zip_path, stats_path)
        return zip_path

    def save(self, model, prefix: str = "") -> None:
        """``DIR/<prefix>model.zip`` and its statistics ``DIR/<prefix>vecnormalize.pkl``."""
        save_model_and_stats(model, model.get_vec_normalize_env(), self.out / f"{prefix}model.zip",
                             self.out / f"{prefix}vecnormalize.pkl")

    def evaluate(self, model, logger=None) -> list[dict[str, Any]]:
        if self.evaluator is None:
            return []
        t = time.perf_counter()
        results = self.evaluator.run(LoadedPolicy(model, model.get_vec_normalize_env()).act)
        self.eval_seconds += time.perf_counter() - t
        mean_return = float(np.mean([r["return_g"] for r in results]))
        score = self.scorer.score(results, self.references())
        best = is_better(score.value, self.best_score, self.scorer.keep_latest)
        n = int(model.num_timesteps)
        wall = self.wall_before + time.perf_counter() - self.session_start
        for r, ratio in zip(results, score.ratios):
            self.eval_rows.append({"timesteps": n, "wall_s": round(wall, 2), **r, "fuel_ratio": ratio,
                                   "mean_return_g": mean_return, "score": score.value, "qualified": score.qualified,
                                   "best": best})
        write_evaluations(self.out / "evaluations.csv", self.eval_rows)
        if best:
            self.best_score = score.value
            self.save(model, "best_")
        if logger is not None:
            logger.record("eval/mean_return_g", mean_return)
            logger.record("eval/selection_score", score.value)
            for r in results:
                for key in ("return_g", "fuel_corrected_l_per_100km", "delta_soc", "cutoff_s"):
                    logger.record(f"eval/{key}_{r['cycle']}_{r['scenario']}", r[key])
        if self.verbose:
            worst = max(abs(r["delta_soc"]) for r in results)
            self.log(f"eval @ {n}: {score.describe(self.scorer.short)}{' (new best)' if best else ''}; "
                     f"mean return {mean_return:.1f} g, max |dSOC| {worst:.3f} over {len(results)} runs")
        return results

    def references(self, cycles: list[str] | None = None) -> dict[str, float]:
        """The scorer's reference on ``cycles`` (the evaluation's) × the evaluation scenarios, each computed once
        per run and kept in the config."""
        res = self.config.setdefault("result", {})
        cycles = self.evaluator.cycle_names if cycles is None else cycles
        res["selection_reference"] = compute_references(self.scorer, cycles, self.config["eval"]["scenarios"],
                                                        res.get("selection_reference"))
        return res["selection_reference"]

    def make_model(self, venv, resume_from: tuple[int, Path, Path] | None):
        cfg = self.config
        cls = algorithm_class(cfg["algo"])
        seed = int(cfg["seed"])
        tb = str(self.out / "tb")
        if resume_from is None:
            set_random_seed(seed)
            kwargs = algorithm_kwargs(cfg["algo"], cfg["hyperparams"])
            policy = cfg["hyperparams"].get("policy", "MlpPolicy")
            try:
                return cls(policy, venv, seed=seed, tensorboard_log=tb, verbose=0, device="cpu", **kwargs)
            except AssertionError as exc:  # SB3 checks some hyperparameters with asserts
                raise ValueError(f"{cfg['algo'].upper()} rejects the hyperparameters: {exc}") from None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = cls.load(resume_from[1], env=venv, device="cpu", custom_objects=custom_objects(cfg["hyperparams"]))
        model.tensorboard_log = tb
        # a fresh but reproducible stream for the continued session
        model.set_random_seed(seed + int(model.num_timesteps))
        torch.manual_seed(seed + int(model.num_timesteps))
        replay = checkpoint_paths(self.out, resume_from[0])[2]
        if cfg["algo"] in OFF_POLICY and replay.is_file():
            model.load_replay_buffer(replay)
        return model

    def prepare(self, resume_from: tuple[int, Path, Path] | None = None) -> None:
        """The selection's references, the environment and the model; writes nothing."""
        cfg = self.config
        normalized = cfg["normalize"] is not False
        if resume_from is not None and normalized and not resume_from[2].is_file():
            raise FileNotFoundError(f"{resume_from[2]} not found: the checkpoint has no normalisation statistics")
        if self.evaluator is not None:
            self.references()
        self.raw, self.timed = make_vec_env(cfg)
        self.venv = wrap_normalize(self.raw, cfg, resume_from[2] if resume_from and normalized else None)
        self.model = self.make_model(self.venv, resume_from)
        self.resume_from = resume_from
        self.refit = None
        if isinstance(self.raw, LagrangianVecEnv):
            self.raw.timesteps = int(self.model.num_timesteps)
            if resume_from is not None:
                load_multiplier(self.raw.multiplier, resume_from[1])
        init = cfg.get("init") or {}
        kwargs = env_kwargs(cfg["env"])
        seed = int(cfg["seed"])
        if resume_from is None and init.get("imitate"):
            rec, self.refit = imitate(self.model, kwargs, init, seed, progress=self.progress)
            cfg.setdefault("result", {})["imitation"] = rec
            loss = ("weighted " if init.get("heat_weight") else "") + "MSE"
            if init.get("cost_weight"):
                loss += f" + {init['cost_weight']:g} x the teacher's cost"
            excess = rec.get("cost_excess_g_per_step")
            self.log(f"imitation of {rec['teacher']}: {rec['steps']} steps of {rec['episodes']} episodes, policy "
                     f"mean fitted ({loss} {rec['mse_first']} -> {rec['mse_last']}) in {rec['wall_s']} s"
                     + ("" if excess is None else f"; {excess} g per step dearer than the teacher by its cost"))
        elif resume_from is not None:
            self.refit = resumed_refit(self.model, kwargs, init, seed)

    def execute(self) -> dict[str, Any]:
        """Learn up to the total, then save the final model and its evaluation; returns the ``result`` section."""
        cfg, model = self.config, self.model
        (self.out / CHECKPOINTS).mkdir(parents=True, exist_ok=True)
        self.venv.seed(int(cfg["seed"]) + int(model.num_timesteps))
        done_before = int(model.num_timesteps)
        remaining = int(cfg["total_timesteps"]) - done_before
        callback = RunCallback(self)
        callbacks = callback if self.refit is None else CallbackList([callback, self.refit])
        t0 = time.perf_counter()
        if remaining > 0:
            with stop_on_signals(callback):
                model.learn(remaining, callback=callbacks, reset_num_timesteps=self.resume_from is None,
                            tb_log_name=cfg["algo"].upper(), progress_bar=self.progress)
        result = self.session_summary(model, done_before, time.perf_counter() - t0, self.timed.seconds)
        if self.refit is not None:
            self.config.setdefault("result", {}).setdefault("imitation", {})["refit"] = self.refit.summary()
        if callback.stop_signal is not None:
            path = self.checkpoint(model)
            self.record_session(result, finished=False)
            self.raw.close()
            name = signal.Signals(callback.stop_signal).name
            raise TrainingInterrupted(f"training stopped by {name} at {model.num_timesteps} of "
                                      f"{cfg['total_timesteps']} timesteps; checkpoint {path}; continue with: "
                                      f"python train.py --resume {self.out}", 128 + int(callback.stop_signal))
        evaluated = bool(self.eval_rows) and self.eval_rows[-1]["timesteps"] == model.num_timesteps
        if self.evaluator is not None and not evaluated:
            self.evaluate(model, model.logger if model.num_timesteps > done_before else None)
        self.save(model)
        if not (self.out / "best_model.zip").is_file():
            self.save(model, "best_")
        self.checkpoint(model)
        if self.evaluator is not None and self.config["eval"].get("final_cycles"):
            final_validation(self)
        self.record_session(result, finished=True)
        self.raw.close()
        plot_training_curve(self.out)
        return self.config["result"]

    def session_summary(self, model, done_before: int, train_s: float, env_s: float) -> dict[str, Any]:
        steps = int(model.num_timesteps) - done_before
        loop_s = train_s - self.eval_seconds  # the training loop, evaluation excluded
        return {"timesteps_done": int(model.num_timesteps), "session_wall_s": round(train_s, 2),
                "session_timesteps": steps, "steps_per_s": round(steps / train_s, 1) if train_s > 0 else None,
                "env_s": round(env_s, 2), "eval_s": round(self.eval_seconds, 2),
                "env_share": round(env_s / loop_s, 4) if loop_s > 0 else None}

    def record_session(self, session: dict[str, Any], finished: bool) -> None:
        cfg = self.config
        res = dict(cfg.get("result") or {})
        sessions = [*(res.get("sessions") or []), session]
        wall = sum(s["session_wall_s"] for s in sessions)
        res.update(finished=finished, timesteps_done=session["timesteps_done"], wall_s=round(wall, 2),
                   sessions=sessions, env_share=session["env_share"], steps_per_s=session["steps_per_s"])
        m = self.multiplier
        if m is not None:
            res["lagrangian"] = {"lambda": round(m.lam, 6), "updates": len(m.history),
                                 "last_cost_s_per_h": m.history[-1]["cost_s_per_h"] if m.history else None}
            write_csv(self.out / "lagrangian.csv", m.HISTORY_COLUMNS,
                      [[row[k] for k in m.HISTORY_COLUMNS] for row in m.history])
        if self.eval_rows:
            best = min(self.eval_rows, key=lambda r: r["score"])
            res["best_eval"] = {"timesteps": best["timesteps"], "mean_return_g": best["mean_return_g"],
                                "score": best["score"], "qualified": best["qualified"], "selection": self.scorer.name}
        cfg["result"] = res
        save_run_config(self.out, cfg)


def train(config: dict[str, Any], out_dir: str | Path, *, progress: bool = True, verbose: int = 1,
          overwrite: bool = False, log: Callable[[str], None] | None = None,
          run_class: type[TrainingRun] = TrainingRun) -> dict[str, Any]:
    """Train a new run into ``out_dir`` (new or empty unless ``overwrite``); returns the ``result`` section of its
    config. Raises :class:`TrainingInterrupted` after saving a checkpoint when stopped by a signal.
    ``run_class`` runs the session (a sweep's trial reports to Ray Tune through its own :class:`TrainingRun`).
    """
    out = check_new_dir(out_dir, overwrite=overwrite)
    validate_config(config)
    _limit_threads()
    run = run_class(config, out, progress=progress, verbose=verbose, log=log)
    run.prepare()
    save_run_config(out, config)
    _append_command(out, config.get("command"))
    return run.execute()


def resume(run_dir: str | Path, *, progress: bool = True, verbose: int = 1, command: str | None = None,
           log: Callable[[str], None] | None = None, run_class: type[TrainingRun] = TrainingRun) -> dict[str, Any]:
    """Continue the run in ``run_dir`` from its latest complete checkpoint up to its total timesteps."""
    out = Path(run_dir)
    config = load_run_config(out)
    validate_config(config)
    log = log or _print
    if (config.get("result") or {}).get("finished") and (out / "model.zip").is_file():
        log(f"{out}: already finished ({config['result']['timesteps_done']} timesteps); nothing to do")
        return config["result"]
    check_writable_dir(out)
    _limit_threads()
    _append_command(out, command)
    start = (checkpoint_files(out) or [None])[-1]
    log(f"{out}: no checkpoint yet; starting the run over" if start is None else
        f"{out}: resuming from {start[1].name} ({start[0]} of {config['total_timesteps']} timesteps)")
    run = run_class(config, out, progress=progress, verbose=verbose, log=log)
    run.prepare(resume_from=start)
    return run.execute()


def _print(msg: str) -> None:
    print(msg, flush=True)


def _append_command(out: Path, command: str | None) -> None:
    if command:
        with open(out / "command.txt", "a") as fh:
            fh.write(command.rstrip("\n") + "\n")


def _limit_threads() -> None:
    """Torch on one thread (``HEV_TORCH_THREADS`` to change): with these small MLPs two threads gained
    only ~7 % here (35k vs 33k env-steps/s on 2 cores), and one leaves a core to other jobs."""
    torch.set_num_threads(int(os.environ.get("HEV_TORCH_THREADS", "1")))
