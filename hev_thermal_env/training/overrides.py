"""``--hp key=value`` overrides of the hyperparameter files: parsing and dotted-key merging."""

from __future__ import annotations

import copy
from collections.abc import Iterable
from typing import Any

import yaml


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
