"""The algorithms' hyperparameter files (``agents/hyperparams/``), the SB3 constructor arguments built from
them, their checks and the ``--hp`` overrides (:func:`parse_overrides`): a file holds run settings
(:data:`RUN_KEYS`) and any argument of the algorithm's constructor the training does not set itself
(:data:`MANAGED_KEYS`). Unknown keys (also inside ``policy_kwargs``) and values of the wrong type are refused in one
line naming the key and the closest valid one. A file is the project's flat mapping (``ppo.yaml``) or rl-zoo3's
(``sac.yaml``, which rl-zoo3 reads unchanged): :func:`read_hyperparams_file`.

The config's sections are typed records (:class:`Section`), validated in one place with one-line errors naming the
section, the field and the value (``init.episodes must be a whole number of at least 1, got 0``).
"""

from __future__ import annotations

import ast
import collections.abc
import copy
import dataclasses
import difflib
import inspect
import math
import types
import typing
from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import torch
import yaml

from hev_thermal_env.agents import HYPERPARAMS_DIR
from hev_thermal_env.agents.policy_files import SCHEDULE_KEYS, algorithm_class, schedule
from hev_thermal_env.io import read_yaml_mapping
from hev_thermal_env.physics.params import Params
from hev_thermal_env.tasks import ENV_ID

#: Keys of a hyperparameter file that describe the run rather than the algorithm's constructor.
RUN_KEYS = ("n_timesteps", "n_envs", "env", "normalize", "eval", "checkpoint_freq", "policy", "constraint")
#: Constructor arguments the training sets itself.
MANAGED_KEYS = ("self", "policy", "env", "seed", "tensorboard_log", "verbose", "device", "_init_setup_model")
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU", "gelu": "GELU",
               "silu": "SiLU"}

_KIND_NAMES = {bool: "true or false", int: "an integer", float: "a number", str: "a string", list: "a list",
               tuple: "a list", dict: "a mapping", type(None): "null", collections.abc.Callable: "lin_<number>"}
#: The section of an rl-zoo3 hyperparameter file with the settings only ``train.py`` reads.
PROJECT_SECTION = "hev_thermal_env"

S = TypeVar("S", bound="Section")


def load_hyperparams(algo: str, path: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameter file of ``algo`` (``agents/hyperparams/<algo>.yaml`` unless ``path``) as a flat dict
    (:func:`read_hyperparams_file`)."""
    algorithm_class(algo)  # validates the name
    p = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo.lower()}.yaml"
    if not p.is_file():
        raise FileNotFoundError(f"hyperparameter file {p} not found")
    return read_hyperparams_file(p)


def read_hyperparams_file(path: str | Path) -> dict[str, Any]:
    """A hyperparameter file in either format (docs/training.md) as the project's flat dict. An rl-zoo3 file's
    section :data:`~hev_thermal_env.tasks.ENV_ID` holds ``n_timesteps``, ``n_envs``, ``policy``, the constructor's
    arguments, ``env_kwargs`` (``gymnasium.make``'s: the ``env`` section, ``cycle`` its ``cycles``) and ``normalize``
    and ``policy_kwargs`` as rl-zoo3's ``"dict(...)"`` strings (read as mappings, ``nn.ReLU`` as the name ``relu``);
    the settings rl-zoo3 has no place for (``eval``, ``checkpoint_freq``, ``init``, ``constraint``) sit in
    :data:`PROJECT_SECTION`, which rl-zoo3 does not read."""
    data = read_yaml_mapping(path)
    env_ids = [k for k in data if str(k).startswith("HevThermal-v")]
    if not env_ids:
        return data
    if env_ids != [ENV_ID] or set(data) - {ENV_ID, PROJECT_SECTION}:
        raise ValueError(f"{path}: an rl-zoo3 file here has the sections {ENV_ID} and {PROJECT_SECTION}, got "
                         f"{', '.join(map(str, data))}")
    flat = {**dict(data[ENV_ID] or {}), **dict(data.get(PROJECT_SECTION) or {})}
    env = dict(flat.pop("env_kwargs", None) or {})
    if "cycle" in env:
        env["cycles"] = env.pop("cycle")
    if env:
        flat["env"] = env
    for key in ("normalize", "policy_kwargs"):
        if isinstance(flat.get(key), str):
            flat[key] = zoo_mapping(flat[key], f"{path}: {key}")
    return flat


def zoo_mapping(text: str, where: str) -> dict[str, Any]:
    """rl-zoo3's ``"dict(key=value, ...)"`` string as a mapping, read without evaluating it: literal values, and
    ``nn.<Activation>`` as its name in :data:`ACTIVATIONS`."""
    names = {v: k for k, v in ACTIVATIONS.items()}
    try:
        call = ast.parse(text.strip(), mode="eval").body
        if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "dict"
                and not call.args and all(k.arg for k in call.keywords)):
            raise ValueError("expected dict(key=value, ...)")
        out = {}
        for kw in call.keywords:
            v = kw.value
            if isinstance(v, ast.Attribute) and isinstance(v.value, ast.Name) and v.value.id == "nn":
                if v.attr not in names:
                    raise ValueError(f"nn.{v.attr}: expected one of {', '.join('nn.' + n for n in names)}")
                out[kw.arg] = names[v.attr]
            else:
                out[kw.arg] = ast.literal_eval(v)
        return out
    except (SyntaxError, ValueError) as exc:
        raise ValueError(f"{where}: {text!r}: {exc}") from None


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


def parse_value(text: str) -> Any:
    """A ``--hp`` value, as YAML: ``0.99``, ``[64, 64]``, ``{net_arch: [64, 64]}``, ``lin_3e-4``."""
    s = text.strip()
    try:
        return yaml.safe_load(s) if s else None
    except yaml.YAMLError as exc:
        raise ValueError(f"cannot parse {text!r} as YAML ({' '.join(str(exc).split())})") from None


def parse_overrides(items: Iterable[str]) -> dict[str, Any]:
    """``["gamma=0.99", "policy_kwargs.net_arch=[64,64]"]`` -> ``{"gamma": 0.99, "policy_kwargs.net_arch": [64, 64]}``.

    Dotted keys are resolved by :func:`apply_overrides`."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        if not sep or not all(key.strip().split(".")):
            raise ValueError(f"--hp {item!r}: expected key=value (e.g. gamma=0.99 or policy_kwargs.net_arch=[64,64])")
        out[key.strip()] = parse_value(value)
    return out


def apply_overrides(hp: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """A deep copy of ``hp`` with dotted-key overrides applied (mappings are merged, not replaced)."""
    hp = copy.deepcopy(hp)
    for key, value in overrides.items():
        *path, last = key.split(".")
        node = hp
        for part in path:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        node[last] = {**node[last], **value} if isinstance(value, dict) and isinstance(node.get(last), dict) else value
    return hp


def setting(default: Any, doc: str, *, kind: str = "any", min: float | None = None, max: float | None = None,
            min_exclusive: bool = False, what: str = "") -> Any:
    """A field of a :class:`Section`: its default (a mapping or list is copied for each record), meaning, kind
    (``whole``: an integer of at least ``min``, at most ``max`` if given; ``number``: a number in [``min``, ``max``], or
    (``min``, ``max``] with ``min_exclusive``; ``bool``; ``any``: checked by :meth:`Section.validate`) and range;
    ``what`` follows the range in its error message."""
    meta = {"doc": doc, "kind": kind, "min": min, "max": max, "min_exclusive": min_exclusive, "what": what}
    if isinstance(default, (dict, list)):
        return dataclasses.field(default_factory=lambda: type(default)(default), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def is_number(value: Any) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _problem(f: dataclasses.Field, value: Any) -> str | None:
    """What is wrong with ``value`` for field ``f`` (its kind and range), or None."""
    kind, lo, hi = f.metadata["kind"], f.metadata["min"], f.metadata["max"]
    if kind == "bool" and not isinstance(value, bool):
        return "must be true or false"
    if kind == "whole" and (not isinstance(value, int) or isinstance(value, bool) or value < lo
                            or (hi is not None and value > hi)):
        return f"must be a whole number of at least {lo}" if hi is None else f"must be a whole number in [{lo}, {hi}]"
    if kind == "number":
        excl = f.metadata["min_exclusive"]
        if not (is_number(value) and (value > lo if excl else value >= lo) and (hi is None or value <= hi)):
            return (f"must be a number of at least {lo:g}" if hi is None else
                    f"must be a number in {'(' if excl else '['}{lo:g}, {hi:g}]{f.metadata['what']}")
    return None


@dataclasses.dataclass(frozen=True)
class Section:
    """Base class: a section of the run config (:attr:`NAME` in its messages; empty: the top level)."""

    NAME: ClassVar[str] = "section"

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            problem = _problem(f, getattr(self, f.name))
            if problem:
                raise ValueError(f"{self.NAME + '.' if self.NAME else ''}{f.name} {problem}, got "
                                 f"{getattr(self, f.name)!r}")
        self.validate()

    def validate(self) -> None:
        """Checks across fields; subclasses raise a one-line ``ValueError`` naming them."""

    @classmethod
    def from_dict(cls: type[S], data: dict[str, Any] | None) -> S:
        """The section from a mapping (None: every default); unknown keys raise ``ValueError``."""
        if data is not None and not isinstance(data, dict):
            names = ", ".join(f.name for f in dataclasses.fields(cls))
            raise ValueError(f"{cls.NAME or 'config'}={data!r}: expected a mapping ({names})")
        check_known(f"{cls.NAME or 'run'} setting", data or {}, [f.name for f in dataclasses.fields(cls)])
        return cls(**(data or {}))

    def to_dict(self) -> dict[str, Any]:
        """The fields in their order, as plain values (the YAML form)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_yaml(cls: type[S], path: str | Path) -> S:
        """The section from a YAML file holding it; errors name the file."""
        try:
            return cls.from_dict(yaml.safe_load(Path(path).read_text()))
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None

    #: The YAML text of :meth:`to_dict`, also written to ``path`` if given (the vehicle records' method).
    to_yaml = Params.to_yaml
