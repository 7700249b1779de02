"""Typed, frozen parameter records with validation and a YAML round-trip.

Every component module defines one ``Params`` dataclass deriving from :class:`Params`.
Each field carries its unit in its name and an admissible range in its metadata
(``field(default=..., metadata={"min": ..., "max": ..., "doc": ...})``), so that an
invalid value is reported with the field's name, the value and the allowed range.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, TypeVar

import yaml

P = TypeVar("P", bound="Params")


def spec(default: Any, doc: str, *, min: float | None = None, max: float | None = None,
         min_exclusive: bool = False) -> Any:
    """A dataclass field with a documented meaning and an admissible range."""
    return dataclasses.field(
        default=default,
        metadata={"doc": doc, "min": min, "max": max, "min_exclusive": min_exclusive},
    )


class ConfigError(ValueError):
    """An invalid configuration value; the message names the field."""


@dataclasses.dataclass(frozen=True)
class Params:
    """Base class: validation on construction, dict and YAML conversion."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, Params):
                continue
            if isinstance(value, (list, tuple)):
                object.__setattr__(self, f.name, tuple(float(v) for v in value))
                values = getattr(self, f.name)
            elif isinstance(value, bool):
                continue
            elif isinstance(value, (int, float)):
                values = (float(value),)
            else:
                continue
            lo, hi = f.metadata.get("min"), f.metadata.get("max")
            for v in values:
                if not math.isfinite(v):
                    raise ConfigError(f"{type(self).__name__}.{f.name}: value {v} is not finite")
                if lo is not None and (v < lo or (f.metadata.get("min_exclusive") and v == lo)):
                    op = ">" if f.metadata.get("min_exclusive") else ">="
                    raise ConfigError(
                        f"{type(self).__name__}.{f.name}: value {v} is out of range (must be {op} {lo})")
                if hi is not None and v > hi:
                    raise ConfigError(
                        f"{type(self).__name__}.{f.name}: value {v} is out of range (must be <= {hi})")
        self.validate()

    def validate(self) -> None:
        """Cross-field checks; subclasses raise :class:`ConfigError` naming the fields."""

    def replace(self: P, **changes: Any) -> P:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Params):
                out[f.name] = v.to_dict()
            elif isinstance(v, tuple):
                out[f.name] = [float(x) for x in v]
            else:
                out[f.name] = v
        return out

    @classmethod
    def from_dict(cls: type[P], data: dict[str, Any], *, where: str = "") -> P:
        if not isinstance(data, dict):
            raise ConfigError(f"{where or cls.__name__}: expected a mapping, got {type(data).__name__}")
        known = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ConfigError(
                f"{where or cls.__name__}: unknown field(s) {unknown}; known: {sorted(known)}")
        kwargs: dict[str, Any] = {}
        for name, value in data.items():
            f = known[name]
            default = getattr(cls, name, None) if f.default is dataclasses.MISSING else f.default
            if f.default_factory is not dataclasses.MISSING:  # nested Params
                default = f.default_factory()
            if isinstance(default, Params):
                kwargs[name] = type(default).from_dict(value, where=f"{where or cls.__name__}.{name}")
            elif isinstance(default, bool):
                if not isinstance(value, bool):
                    raise ConfigError(f"{where or cls.__name__}.{name}: expected true/false, got {value!r}")
                kwargs[name] = value
            elif isinstance(default, tuple):
                if not isinstance(value, (list, tuple)) or not all(
                        isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
                    raise ConfigError(f"{where or cls.__name__}.{name}: expected a list of numbers, got {value!r}")
                kwargs[name] = tuple(float(x) for x in value)
            elif isinstance(default, (int, float)):
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise ConfigError(f"{where or cls.__name__}.{name}: expected a number, got {value!r}")
                kwargs[name] = value
            else:
                kwargs[name] = value
        try:
            return cls(**kwargs)
        except ConfigError as exc:
            raise ConfigError(f"{where + ': ' if where else ''}{exc}") from None

    def to_yaml(self, path: str | Path | None = None) -> str:
        text = yaml.safe_dump(self.to_dict(), sort_keys=False)
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_yaml(cls: type[P], path_or_text: str | Path) -> P:
        """Load from a YAML file path or YAML text; errors name the file and the field."""
        where = cls.__name__
        if isinstance(path_or_text, Path) or (isinstance(path_or_text, str) and "\n" not in path_or_text
                                              and path_or_text.endswith((".yaml", ".yml"))):
            path = Path(path_or_text)
            if not path.is_file():
                raise ConfigError(f"{path}: no such config file")
            text = path.read_text()
            where = str(path)
        else:
            text = str(path_or_text)
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ConfigError(f"{where}: not valid YAML ({str(exc).splitlines()[0]})") from None
        if data is None:
            raise ConfigError(f"{where}: the config is empty")
        return cls.from_dict(data, where=where)

    @classmethod
    def describe(cls) -> list[tuple[str, Any, str]]:
        """(name, default, doc) for every field: the parameter table in the docs."""
        rows = []
        for f in dataclasses.fields(cls):
            default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
            rows.append((f.name, default, f.metadata.get("doc", "")))
        return rows
