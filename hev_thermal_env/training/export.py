"""Export a trained policy as a small package (how ``agents/policies/ppo_default/`` was made), or a sweep's best."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hev_thermal_env.agents.policy_files import (
    checkpoint_files,
    find_run_config,
    load_obs_normalizer,
    load_sb3_model,
    resolve_model_path,
    stats_path_for,
)
from hev_thermal_env.io import atomic_write_bytes, atomic_write_text

from .artifacts import model_bytes
from .config import save_run_config


def export_policy(run: str | Path, out_dir: str | Path, readme: str | None = None) -> Path:
    """Copy a trained policy into ``out_dir`` as a small package: ``model.zip`` (without the optimizer's
    state), ``vecnormalize.pkl`` and ``config.yaml`` (and ``README.md`` if given)."""
    model_path = resolve_model_path(run)
    config = find_run_config(model_path)
    if config is None:
        raise FileNotFoundError(f"no config.yaml next to {model_path}: export needs a train.py run")
    model = load_sb3_model(model_path, config["algo"], config.get("hyperparams"))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if config["normalize"] is not False:
        stats_path = stats_path_for(model_path)
        load_obs_normalizer(stats_path)  # checks it
        atomic_write_bytes(out / "vecnormalize.pkl", stats_path.read_bytes())
    atomic_write_bytes(out / "model.zip", model_bytes(model, exclude_optimizer_state=True))
    config = {**config, "exported_from": {"model": model_path.name, "timesteps": int(model.num_timesteps)}}
    save_run_config(out, config)
    if readme is not None:
        atomic_write_text(out / "README.md", readme)
    return out


def export_best(report: Any, dest: Path, settings: dict[str, Any]) -> Path:
    """Export the best trial of a sweep's report (:class:`~.sweep.SweepReport`) as a policy package in ``dest``: its
    final model, from its latest Tune checkpoint (the latest training checkpoint of a trial stopped early)."""
    best = report.best
    source = best.checkpoint if best.checkpoint is not None else best.run_dir
    model = source / "model.zip"
    if not model.is_file():
        ckpts = checkpoint_files(source)
        if not ckpts:
            raise FileNotFoundError(f"no model in the best trial's checkpoint {source}")
        model = ckpts[-1][1]
    config = next(c for c in report.configs if c.config_id == best.config_id)
    lines = [f"# Best trial of a sweep ({settings['algo']})", "",
             f"Trial {best.trial_id}, configuration {best.config_id}, seed {best.seed}, {best.timesteps} env-steps "
             f"({best.status}); validation return {best.score:.1f} g; configuration IQM over "
             f"{len(config.scores)} seed(s) {config.iqm:.1f} g.", "", "Hyperparameters searched:", ""]
    lines += [f"- `{k}`: {v!r}" for k, v in best.hyperparams.items()] or ["- (none: a multi-seed study)"]
    return export_policy(model, dest, readme="\n".join(lines) + "\n")
