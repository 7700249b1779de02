"""Typed, frozen parameter records with validation, a YAML round-trip and the packed layout the kernels read.

Each field of a component's :class:`Params` carries its unit in its name and its meaning and admissible range in its
metadata (:func:`spec`). A :class:`Layout` places each field in the packed float64 vector a kernel reads;
:meth:`Layout.index` gives the module its offsets by slot name (``IDX = LAYOUT.index()``, ``gl[IDX.mass_kg]``): a
namedtuple, which numba compiles in as constants. Reordering, adding or removing fields cannot hand a kernel the wrong
parameter, and a field that no slot packs is an error.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np
import yaml

P = TypeVar("P", bound="Params")

RPM = math.pi / 30.0
"""rad/s per rpm."""


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
        """Cross-field checks; subclasses raise :class:`ConfigError` naming the fields (:meth:`require`)."""

    def require(self, ok: bool, name: str, message: str) -> None:
        """Raise a :class:`ConfigError` ``"<Class>.<name>: <message>"`` unless ``ok``."""
        if not ok:
            raise ConfigError(f"{type(self).__name__}.{name}: {message}")

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
            elif isinstance(default, tuple):  # made a tuple of floats by __post_init__
                if not isinstance(value, (list, tuple)) or not all(_is_number(x) for x in value):
                    raise ConfigError(f"{label}.{name}: expected a list of numbers, got {value!r}")
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


@dataclasses.dataclass(frozen=True)
class Slot:
    """``size`` consecutive packed values named ``name``: ``fill(params)``, by default the field of the same name
    (bools as 0/1), a table shorter than ``size`` zero-padded; ``fields``: the fields it packs (default ``name``)."""

    name: str
    size: int = 1
    fill: Callable[[Any], Any] | None = None
    fields: tuple[str, ...] | None = None

    def value(self, params: Any) -> np.ndarray:
        arr = np.atleast_1d(np.asarray(getattr(params, self.name) if self.fill is None else self.fill(params),
                                       dtype=np.float64))
        if arr.size > self.size:
            raise ValueError(f"{type(params).__name__}: {self.name} has {arr.size} values, "
                             f"the layout holds {self.size}")
        return arr

    def packs(self) -> tuple[str, ...]:
        return (self.name,) if self.fields is None else self.fields


class Layout:
    """Offsets of named slots in a packed parameter vector, and the packing itself; ``unpacked`` fields are in none
    (a field that is in no slot and not unpacked is an error)."""

    def __init__(self, params_cls: type, slots: Iterable[Slot], *, unpacked: Iterable[str] = ()):
        self.params_cls, self.slots, self._offset = params_cls, tuple(slots), {}
        pos = 0
        for slot in self.slots:
            if slot.name in self._offset:
                raise ValueError(f"{params_cls.__name__}: slot {slot.name!r} appears twice in the layout")
            self._offset[slot.name] = pos
            pos += slot.size
        self.size = pos
        packed = {name for slot in self.slots for name in slot.packs()} | set(unpacked)
        missing = [f.name for f in dataclasses.fields(params_cls) if f.name not in packed]
        if missing:
            raise ValueError(f"{params_cls.__name__}: fields {missing} are in no slot of the packed layout")

    @classmethod
    def of_fields(cls, params_cls: type, *, replace: dict[str, Slot | Sequence[Slot]] | None = None,
                  derived: dict[str, Callable[[Any], Any]] | None = None, unpacked: Iterable[str] = ()) -> Layout:
        """One slot per field in declaration order (``replace`` maps a field to its own slot(s): a unit conversion,
        a padded table), then one slot per ``derived`` name filled by its function of the params (a constant the
        kernels would otherwise recompute per row); ``unpacked`` fields are left out."""
        replace, unpacked = replace or {}, tuple(unpacked)
        slots: list[Slot] = []
        for f in dataclasses.fields(params_cls):
            if f.name not in unpacked:
                mapped = replace.get(f.name, Slot(f.name))
                slots.extend([mapped] if isinstance(mapped, Slot) else mapped)
        slots += [Slot(name, fill=fill, fields=()) for name, fill in (derived or {}).items()]
        return cls(params_cls, slots, unpacked=unpacked)

    def __getitem__(self, name: str) -> int:
        try:
            return self._offset[name]
        except KeyError:
            raise KeyError(f"{self.params_cls.__name__} layout has no slot {name!r}") from None

    def index(self) -> tuple:
        """The offset of every slot as a namedtuple field of the same name (``IDX.mass_kg``)."""
        return collections.namedtuple(f"{self.params_cls.__name__}Index", list(self._offset))(**self._offset)

    def pack(self, params: Any) -> np.ndarray:
        if not isinstance(params, self.params_cls):
            raise TypeError(f"expected {self.params_cls.__name__}, got {type(params).__name__}")
        v = np.zeros(self.size)
        for slot in self.slots:
            arr = slot.value(params)
            v[self._offset[slot.name]:self._offset[slot.name] + arr.size] = arr
        return v
