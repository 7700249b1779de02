"""Export a trained policy as a small package (how ``agents/policies/ppo_default/`` was made)."""

from __future__ import annotations

from pathlib import Path

from hev_thermal_env.agents.policy_files import (
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
    config = dict(config)
    config["exported_from"] = {"model": model_path.name, "timesteps": int(model.num_timesteps)}
    save_run_config(out, config)
    if readme is not None:
        atomic_write_text(out / "README.md", readme)
    return out
