"""The algorithms' hyperparameter files (``agents/hyperparams/``), the SB3 constructor arguments built from
them and their checks: a file holds run settings (:data:`RUN_KEYS`) and any argument of the algorithm's constructor
(``PPO``, ``SAC``, ``TQC``, ``RecurrentPPO``) the training does not set itself (:data:`MANAGED_KEYS`). Unknown keys
(also inside ``policy_kwargs``) and values of the wrong type are refused in one line naming the key and the closest
valid one.
"""

from __future__ import annotations

import collections.abc
import difflib
import inspect
import types
import typing
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import torch

from hev_thermal_env.agents import HYPERPARAMS_DIR
from hev_thermal_env.agents.policy_files import SCHEDULE_KEYS, algorithm_class, schedule
from hev_thermal_env.io import read_yaml_mapping

#: Keys of a hyperparameter file that describe the run rather than the algorithm's constructor.
RUN_KEYS = ("n_timesteps", "n_envs", "env", "normalize", "eval", "checkpoint_freq", "policy", "save_replay_buffer",
            "constraint")

#: Constructor arguments the training sets itself.
MANAGED_KEYS = ("self", "policy", "env", "seed", "tensorboard_log", "verbose", "device", "_init_setup_model")

ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU",
               "silu": "SiLU"}

_KIND_NAMES = {bool: "true or false", int: "an integer", float: "a number", str: "a string", list: "a list",
               tuple: "a list", dict: "a mapping", type(None): "null", collections.abc.Callable: "lin_<number>"}


def load_hyperparams(algo: str, path: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameter file of ``algo`` (``agents/hyperparams/<algo>.yaml`` unless ``path``) as a dict."""
    algorithm_class(algo)  # validates the name
    p = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo.lower()}.yaml"
    if not p.is_file():
        raise FileNotFoundError(f"hyperparameter file {p} not found")
    return read_yaml_mapping(p)


def algorithm_kwargs(algo: str, hp: dict[str, Any]) -> dict[str, Any]:
    """Constructor arguments for the SB3 class from the config's ``hyperparams``."""
    kwargs = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    for key in SCHEDULE_KEYS:
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


def check_known(what: str, keys: Iterable[Any], valid: Iterable[str]) -> None:
    """Raise a one-line ValueError naming the first unknown key and the closest valid one."""
    valid = sorted(valid)
    unknown = sorted(str(k) for k in keys if k not in valid)
    if unknown:
        close = difflib.get_close_matches(unknown[0], valid, n=1)
        hint = f"did you mean {close[0]!r}?" if close else f"valid: {', '.join(valid)}"
        raise ValueError(f"unknown {what} {unknown[0]!r} ({hint})")


def check_hyperparams(algo: str, hp: dict[str, Any]) -> None:
    """Names and value types of the ``hyperparams`` of a run config; one-line ValueError on the first problem."""
    cls = algorithm_class(algo)
    params = {k: p for k, p in inspect.signature(cls.__init__).parameters.items() if k not in MANAGED_KEYS}
    managed = sorted(k for k in hp if k in MANAGED_KEYS and k not in RUN_KEYS)
    if managed:
        hint = " (use --seed)" if managed[0] == "seed" else ""
        raise ValueError(f"hyperparameter {managed[0]!r} is set by the training itself{hint}")
    check_known(f"{cls.__name__} hyperparameter", hp, [*params, *RUN_KEYS])
    policy = hp.get("policy", "MlpPolicy")
    if policy not in cls.policy_aliases:
        raise ValueError(f"unknown policy {policy!r}; known policies: {', '.join(cls.policy_aliases)}")
    policy_params = set(inspect.signature(cls.policy_aliases[policy].__init__).parameters)
    policy_params -= {"self", "observation_space", "action_space", "lr_schedule"}
    policy_kwargs = hp.get("policy_kwargs") or {}
    if not isinstance(policy_kwargs, dict):
        raise ValueError(f"hyperparameter policy_kwargs={policy_kwargs!r}: expected a mapping")
    check_known("policy_kwargs key", policy_kwargs, policy_params)
    kwargs = algorithm_kwargs(algo, hp)
    for key, value in kwargs.items():
        kinds = _kinds(params[key].annotation)
        if kinds is not None and not _admits(kinds, value):
            names = list(dict.fromkeys(_KIND_NAMES[k] for k in kinds))
            raise ValueError(f"hyperparameter {key}={hp[key]!r}: expected {' or '.join(names)}")


def _kinds(annotation: Any) -> set | None:
    """The plain kinds of value an annotation admits, or None when it names anything else (a class...)."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        parts = [_kinds(a) for a in typing.get_args(annotation)]
        return None if any(p is None for p in parts) else set().union(*parts)
    if annotation in _KIND_NAMES:
        return {annotation}
    if origin in (dict, list, tuple, collections.abc.Callable):
        return {origin}
    return None


def _admits(kinds: set, value: Any) -> bool:
    if isinstance(value, bool):
        return bool in kinds
    if isinstance(value, int):
        return bool(kinds & {int, float})
    if isinstance(value, (list, tuple)):
        return bool(kinds & {list, tuple})
    if callable(value) and not isinstance(value, type):
        return collections.abc.Callable in kinds
    return type(value) in kinds
