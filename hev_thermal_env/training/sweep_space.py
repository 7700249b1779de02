"""The search space of a sweep: which hyperparameters vary, over what, and which are fixed.

A space is a mapping from a hyperparameter key (any ``--hp`` key, dotted keys included:
``policy_kwargs.net_arch``, ``env.reward.soc_deviation_weight``) to either a fixed value or one
sampler, written as a one-key mapping::

    learning_rate: {loguniform: [1.0e-4, 1.0e-3]}   # log-uniform between the bounds
    gamma: {uniform: [0.95, 0.99]}                  # uniform between the bounds
    n_epochs: {int: [3, 10]}                        # whole numbers, both bounds included
    policy_kwargs.net_arch: {choice: [[64, 64], [128, 128]]}
    ent_coef: 0.0                                   # fixed

A space without any sampler is a multi-seed study of one configuration. Choices travel through
Ray Tune and Optuna as their YAML text (Optuna's categorical values must be scalars) and are read
back with :func:`~hev_thermal_env.training.overrides.parse_value`.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any

import yaml

from hev_thermal_env.io import read_yaml_mapping

from .overrides import parse_value

SAMPLERS = ("uniform", "loguniform", "int", "choice")

#: What ``train.py sweep`` searches when no ``--space`` file is given.
DEFAULT_SPACES: dict[str, dict[str, Any]] = {
    "ppo": {"learning_rate": {"loguniform": [1.0e-4, 1.0e-3]}, "gamma": {"uniform": [0.95, 0.99]},
            "gae_lambda": {"choice": [0.9, 0.95, 0.98]}, "clip_range": {"choice": [0.1, 0.2, 0.3]},
            "n_epochs": {"int": [3, 10]}},
    "sac": {"learning_rate": {"loguniform": [1.0e-4, 1.0e-3]}, "gamma": {"uniform": [0.95, 0.99]},
            "tau": {"loguniform": [1.0e-3, 2.0e-2]}, "batch_size": {"choice": [128, 256, 512]}},
}


def sampler_of(value: Any) -> str | None:
    """The sampler name of a space entry, or None for a fixed value."""
    if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in SAMPLERS:
        return next(iter(value))
    return None


def load_space(path: str | Path | None, algo: str) -> dict[str, Any]:
    """The space in the YAML file ``path`` (checked), or the default space of ``algo``."""
    if path is None:
        if algo not in DEFAULT_SPACES:
            raise ValueError(f"no default search space for {algo!r}; give one with --space FILE")
        return dict(DEFAULT_SPACES[algo])
    space = read_yaml_mapping(path)
    check_space(space, where=str(path))
    return space


def check_space(space: dict[str, Any], where: str = "search space") -> None:
    """One-line ``ValueError`` naming the key and value of a malformed sampler."""
    for key, value in space.items():
        kind = sampler_of(value)
        if kind is None:
            name = str(next(iter(value))) if isinstance(value, dict) and len(value) == 1 else ""
            close = difflib.get_close_matches(name, SAMPLERS, n=1) if name else []
            if close:  # {unifrom: [..]} is a misspelt sampler, not a mapping to fix
                raise ValueError(f"{where}: {key}: unknown sampler {name!r} (did you mean {close[0]!r}?)")
            continue
        args = value[kind]
        if kind == "choice":
            if not isinstance(args, list) or not args:
                raise ValueError(f"{where}: {key}: choice needs a non-empty list, got {args!r}")
            continue
        if not (isinstance(args, list) and len(args) == 2 and all(_is_number(a) for a in args)):
            raise ValueError(f"{where}: {key}: {kind} needs [low, high] numbers, got {args!r}")
        low, high = (float(a) for a in args)
        if not low < high:
            raise ValueError(f"{where}: {key}: {kind} needs low < high, got {args!r}")
        if kind == "loguniform" and low <= 0:
            raise ValueError(f"{where}: {key}: loguniform needs positive bounds, got {args!r}")
        if kind == "int" and not all(float(a).is_integer() for a in args):
            raise ValueError(f"{where}: {key}: int needs whole-number bounds, got {args!r}")


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(float(x))


def tunable_keys(space: dict[str, Any]) -> list[str]:
    """The keys that vary, in the space's order."""
    return [k for k, v in space.items() if sampler_of(v) is not None]


def fixed_values(space: dict[str, Any]) -> dict[str, Any]:
    """The keys that do not vary, with their values."""
    return {k: v for k, v in space.items() if sampler_of(v) is None}


def encode_choice(value: Any) -> str:
    """A choice as the text Optuna and Tune carry (``[64, 64]``, ``0.9``)."""
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).strip().removesuffix("...").strip()


def tune_domains(space: dict[str, Any]) -> dict[str, Any]:
    """The Ray Tune search domains of the varying keys."""
    from ray import tune

    out = {}
    for key in tunable_keys(space):
        kind, args = next(iter(space[key].items()))
        if kind == "choice":
            out[key] = tune.choice([encode_choice(v) for v in args])
        elif kind == "uniform":
            out[key] = tune.uniform(float(args[0]), float(args[1]))
        elif kind == "loguniform":
            out[key] = tune.loguniform(float(args[0]), float(args[1]))
        else:
            out[key] = tune.randint(int(args[0]), int(args[1]) + 1)
    return out


def probe_values(space: dict[str, Any]) -> dict[str, Any]:
    """One value of each varying key as a trial would receive it (the low bound, the first choice)."""
    out = {}
    for key in tunable_keys(space):
        kind, args = next(iter(space[key].items()))
        out[key] = encode_choice(args[0]) if kind == "choice" else (int(args[0]) if kind == "int" else float(args[0]))
    return out


def trial_overrides(space: dict[str, Any], sampled: dict[str, Any]) -> dict[str, Any]:
    """The ``--hp`` overrides of one trial: the fixed values and the sampled ones (choices decoded)."""
    out = dict(fixed_values(space))
    for key in tunable_keys(space):
        value = sampled[key]
        kind = sampler_of(space[key])
        if kind == "choice":
            value = parse_value(str(value))
        elif kind == "int":
            value = int(value)
        else:
            value = float(value)
        out[key] = value
    return out
