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
from typing import Any, ClassVar, TypeVar

import numpy as np
import yaml

P = TypeVar("P", bound="Params")


def spec(default: Any, doc: str, *, min: float | None = None, max: float | None = None,
         min_exclusive: bool = False) -> Any:
    """A dataclass field with a documented meaning and an admissible range."""
    return dataclasses.field(default=default, metadata={"doc": doc, "min": min, "max": max,
                                                        "min_exclusive": min_exclusive})


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


class ConfigError(ValueError):
    """An invalid configuration value; the message names the field."""


@dataclasses.dataclass(frozen=True)
class Params:
    """Base class: validation on construction, dict and YAML conversion, and (a component's record) packing."""

    #: The packed layout the kernels read, set by a component's module (``LAYOUT = GliderParams.LAYOUT = ...``).
    LAYOUT: ClassVar[Any] = None

    def pack(self) -> np.ndarray:
        """The float64 vector of :attr:`LAYOUT` that the kernels read."""
        return self.LAYOUT.pack(self)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, (list, tuple)):
                values = tuple(float(v) for v in value)
                object.__setattr__(self, f.name, values)
            elif _is_number(value):
                values = (float(value),)
            else:
                continue
            where, lo, hi = f"{type(self).__name__}.{f.name}", f.metadata.get("min"), f.metadata.get("max")
            exclusive = f.metadata.get("min_exclusive")
            for v in values:
                if not math.isfinite(v):
                    raise ConfigError(f"{where}: value {v} is not finite")
                if lo is not None and (v < lo or (exclusive and v == lo)):
                    raise ConfigError(f"{where}: value {v} is out of range (must be {'>' if exclusive else '>='} {lo})")
                if hi is not None and v > hi:
                    raise ConfigError(f"{where}: value {v} is out of range (must be <= {hi})")
        self.validate()

    def validate(self) -> None:
        """Cross-field checks; subclasses raise :class:`ConfigError` naming the fields."""

    def replace(self: P, **changes: Any) -> P:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain values (nested records as dicts, tuples as lists): the YAML form."""
        return dataclasses.asdict(self, dict_factory=lambda kv: {k: list(v) if isinstance(v, tuple) else v
                                                                  for k, v in kv})

    @classmethod
    def from_dict(cls: type[P], data: dict[str, Any], *, where: str = "") -> P:
        label = where or cls.__name__
        if not isinstance(data, dict):
            raise ConfigError(f"{label}: expected a mapping, got {type(data).__name__}")
        known = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ConfigError(f"{label}: unknown field(s) {unknown}; known: {sorted(known)}")
        kwargs: dict[str, Any] = {}
        for name, value in data.items():
            f = known[name]
            default = f.default if f.default_factory is dataclasses.MISSING else f.default_factory()
            if isinstance(default, Params):
                value = type(default).from_dict(value, where=f"{label}.{name}")
            elif isinstance(default, bool):
                if not isinstance(value, bool):
                    raise ConfigError(f"{label}.{name}: expected true/false, got {value!r}")
            elif isinstance(default, tuple):
                if not isinstance(value, (list, tuple)) or not all(_is_number(x) for x in value):
                    raise ConfigError(f"{label}.{name}: expected a list of numbers, got {value!r}")
                value = tuple(float(x) for x in value)
            elif isinstance(default, (int, float)) and not _is_number(value):
                raise ConfigError(f"{label}.{name}: expected a number, got {value!r}")
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
