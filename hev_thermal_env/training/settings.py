"""Typed sections of a training config: frozen dataclasses whose fields say their kind and range, validated in one
place (:meth:`Section.__post_init__`), with a dict and YAML round-trip.

A field is a :func:`setting` (as the vehicle's records use :func:`~hev_thermal_env.physics.params.spec`): its default,
its meaning, its kind (``whole``: an integer of at least ``min``; ``number``: a number in [``min``, ``max``], or
(``min``, ``max``] with ``min_exclusive``; ``bool``; ``any``: checked by the section's :meth:`Section.validate`).
Errors are one line naming the section, the field and the value (``init.episodes must be a whole number of at least
1, got 0``); an unknown key names the closest known one.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import yaml

from hev_thermal_env.physics.params import Params

from .hyperparams import check_known

S = TypeVar("S", bound="Section")


def setting(default: Any, doc: str, *, kind: str = "any", min: float | None = None, max: float | None = None,
            min_exclusive: bool = False, what: str = "") -> Any:
    """A field of a :class:`Section`: its default (a mapping or list is copied for each record), meaning, kind and
    range; ``what`` follows the range in its error message."""
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
        low_ok = is_number(value) and (
            value > lo if f.metadata["min_exclusive"] else value >= lo)
        if hi is None and not low_ok:
            return f"must be a number of at least {lo:g}"
        if hi is not None and not (low_ok and value <= hi):
            left = "(" if f.metadata["min_exclusive"] else "["
            return f"must be a number in {left}{lo:g}, {hi:g}]{f.metadata['what']}"
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
