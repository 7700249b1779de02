"""Where each parameter sits in the packed float64 vector a compiled kernel reads.

A :class:`Layout` is built from the parameter dataclass, one :class:`Slot` per packed value, and
:meth:`Layout.index` gives the component module its offsets by slot name (``IDX = LAYOUT.index()``; a kernel reads
``gl[IDX.mass_kg]``): a module-level namedtuple, which numba compiles in as constants. Reordering, adding or
removing fields cannot hand a kernel the wrong parameter, and a field that no slot packs is an error.
"""

from __future__ import annotations

import collections
import dataclasses
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np


@dataclasses.dataclass(frozen=True)
class Slot:
    """``size`` consecutive packed values named ``name``: ``fill(params)``, by default the field of the same name
    (bools as 0/1), a table shorter than ``size`` zero-padded; ``fields``: the fields it packs (default ``name``)."""

    name: str
    size: int = 1
    fill: Callable[[Any], Any] | None = None
    fields: tuple[str, ...] | None = None

    def value(self, params: Any) -> np.ndarray:
        raw = getattr(params, self.name) if self.fill is None else self.fill(params)
        arr = np.atleast_1d(np.asarray(raw, dtype=np.float64))
        if arr.size > self.size:
            raise ValueError(f"{type(params).__name__}: {self.name} has {arr.size} values, "
                             f"the layout holds {self.size}")
        return arr

    def packs(self) -> tuple[str, ...]:
        return (self.name,) if self.fields is None else self.fields


class Layout:
    """Offsets of named slots in a packed parameter vector, and the packing itself."""

    def __init__(self, params_cls: type, slots: Iterable[Slot], *, unpacked: Iterable[str] = ()):
        self.params_cls = params_cls
        self.slots = tuple(slots)
        self.unpacked = tuple(unpacked)
        self._offset: dict[str, int] = {}
        pos = 0
        for slot in self.slots:
            if slot.name in self._offset:
                raise ValueError(f"{params_cls.__name__}: slot {slot.name!r} appears twice in the layout")
            self._offset[slot.name] = pos
            pos += slot.size
        self.size = pos
        self.check_covers()

    @classmethod
    def of_fields(cls, params_cls: type, *, replace: dict[str, Slot | Sequence[Slot]] | None = None,
                  derived: dict[str, Callable[[Any], Any]] | None = None, unpacked: Iterable[str] = ()) -> Layout:
        """One slot per field in declaration order (``replace`` maps a field to its own slot(s): a unit conversion,
        a padded table), then one slot per ``derived`` name filled by its function of the params (a constant the
        kernels would otherwise recompute per row); ``unpacked`` fields are left out."""
        replace = replace or {}
        unpacked = tuple(unpacked)
        slots: list[Slot] = []
        for f in dataclasses.fields(params_cls):
            if f.name in unpacked:
                continue
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
        cls = collections.namedtuple(f"{self.params_cls.__name__}Index", list(self._offset))
        return cls(**self._offset)

    def pack(self, params: Any) -> np.ndarray:
        if not isinstance(params, self.params_cls):
            raise TypeError(f"expected {self.params_cls.__name__}, got {type(params).__name__}")
        v = np.zeros(self.size)
        for slot in self.slots:
            arr = slot.value(params)
            start = self._offset[slot.name]
            v[start:start + arr.size] = arr
        return v

    def check_covers(self) -> None:
        """Raise if a dataclass field is packed by no slot (the kernels could not see it)."""
        packed = {name for slot in self.slots for name in slot.packs()} | set(self.unpacked)
        missing = [f.name for f in dataclasses.fields(self.params_cls) if f.name not in packed]
        if missing:
            raise ValueError(f"{self.params_cls.__name__}: fields {missing} are in no slot of the packed layout")
