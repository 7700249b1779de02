"""The pre-registered calibration protocol, machine-readable: docs/calibration/parameter_ranges.yaml.

:func:`load` reads it (with errors naming the file, the row and the field); :func:`fitted_parameters` gives the
parameters whose status is ``fitted``, with their bounds exactly as written and their documented starts (the
YAML's ``value``); :func:`locate` finds where each row lives in the code: a field of a ``VehicleConfig``
component or of ``Conditions``, by the YAML's name, or by :data:`FIELD_NAMES` where the code keeps an older name
(the paper's eq 4, mass and area fields). The fit reads its bounds from here, never from the code.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import yaml

from hev_thermal_env.physics import Conditions, VehicleConfig

#: The protocol's machine-readable copy, in a source checkout.
PROTOCOL_YAML = Path(__file__).resolve().parents[2] / "docs" / "calibration" / "parameter_ranges.yaml"
PROTOCOL_MD = PROTOCOL_YAML.with_name("protocol.md")
#: YAML names whose field in the code has another name: (record, field); a record is a ``VehicleConfig``
#: attribute or ``"conditions"``.
FIELD_NAMES = {
    "motor_mass_kg": ("thermal", "mass_kg"),
    "motor_cp_j_per_kgk": ("thermal", "cp_j_per_kgk"),
    "cooling_area_m2": ("thermal", "area_m2"),
    "h_air_base_w_per_m2k": ("thermal", "h_air_base"),
    "h_air_natural_w_per_m2k": ("thermal", "h_air_natural"),
    "h_air_forced_w_per_m2k": ("thermal", "h_air_forced"),
}
#: Where a YAML name is searched when :data:`FIELD_NAMES` does not list it, in this order.
RECORDS = ("thermal", "motor", "battery", "glider", "driveline", "engine", "powertrain", "conditions")
STATUSES = ("fixed", "fitted", "derived")
ROW_FIELDS = ("name", "node", "unit", "value", "min", "max", "status", "source")


@dataclasses.dataclass(frozen=True)
class FitParam:
    """A fitted parameter: its bounds [lo, hi] exactly as the protocol's, its documented start, and whether the
    fit's unit coordinate is logarithmic."""

    name: str
    start: float
    lo: float
    hi: float
    log: bool

    def to_unit(self, value: float) -> float:
        if self.log:
            return math.log(value / self.lo) / math.log(self.hi / self.lo)
        return (value - self.lo) / (self.hi - self.lo)

    def from_unit(self, u: float) -> float:
        u = min(max(float(u), 0.0), 1.0)
        if self.log:
            return self.lo * math.exp(u * math.log(self.hi / self.lo))
        return self.lo + u * (self.hi - self.lo)

    def d_value_d_unit(self, value: float) -> float:
        """dθ/dθ̃ at ``value``: maps a unit-coordinate standard error to physical units."""
        return value * math.log(self.hi / self.lo) if self.log else self.hi - self.lo


def load(path: str | Path = PROTOCOL_YAML) -> dict[str, Any]:
    """The protocol's YAML, with every parameter row checked: its fields present, status known, min ≤ value ≤ max."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: the calibration protocol is not there (the calibration runs from a source "
                                "checkout)")
    doc = yaml.safe_load(path.read_text())
    for i, row in enumerate(doc.get("parameters") or []):
        where = f"{path}: parameters[{i}] ({row.get('name', '?')})"
        missing = [k for k in ROW_FIELDS if k not in row]
        if missing:
            raise ValueError(f"{where}: missing field(s) {missing}")
        if row["status"] not in STATUSES:
            raise ValueError(f"{where}: status {row['status']!r} is not one of {list(STATUSES)}")
        if not float(row["min"]) <= float(row["value"]) <= float(row["max"]):
            raise ValueError(f"{where}: value {row['value']} is outside [min, max] = [{row['min']}, {row['max']}]")
    return doc


def parameters(doc: dict[str, Any] | None = None) -> dict[str, dict[str, Any]]:
    """The parameter rows by name."""
    return {row["name"]: row for row in (doc or load())["parameters"]}


def fitted_parameters(doc: dict[str, Any] | None = None) -> tuple[FitParam, ...]:
    """The rows with status ``fitted``, in the YAML's order; log scale where the start rule says so."""
    return tuple(FitParam(r["name"], float(r["value"]), float(r["min"]), float(r["max"]),
                          "log scale" in r.get("start_rule", ""))
                 for r in parameters(doc).values() if r["status"] == "fitted")


def locate(name: str, config: VehicleConfig | None = None) -> tuple[str, str] | None:
    """(record, field) of the YAML parameter ``name`` in the code, or None if no record has such a field."""
    if name in FIELD_NAMES:
        return FIELD_NAMES[name]
    config = config or VehicleConfig()
    for record in RECORDS:
        obj = Conditions() if record == "conditions" else getattr(config, record, None)
        if obj is not None and name in {f.name for f in dataclasses.fields(obj)}:
            return record, name
    return None


def field_of(name: str, config: VehicleConfig | None = None) -> tuple[str, dataclasses.Field]:
    """(record, dataclass field) of ``name``; raises naming the row if the code has no such field."""
    where = locate(name, config)
    if where is None:
        raise KeyError(f"{PROTOCOL_YAML.name}: parameter {name!r} has no field in the code (searched "
                       f"{list(RECORDS)} and {sorted(FIELD_NAMES)})")
    record, field = where
    obj = Conditions() if record == "conditions" else getattr(config or VehicleConfig(), record)
    return record, next(f for f in dataclasses.fields(obj) if f.name == field)


def with_values(config: VehicleConfig, values: dict[str, float]) -> VehicleConfig:
    """``config`` with the YAML parameters ``values`` set on their records (validated again)."""
    changes: dict[str, dict[str, float]] = {}
    for name, value in values.items():
        record, field = field_of(name, config)
        if record == "conditions":
            raise ValueError(f"{name}: a condition of the run, not a parameter of the vehicle")
        changes.setdefault(record, {})[field.name] = float(value)
    return config.replace(**{rec: getattr(config, rec).replace(**ch) for rec, ch in changes.items()})


def value_in_code(name: str, config: VehicleConfig | None = None) -> float:
    """The code's default of the YAML parameter ``name``."""
    config = config or VehicleConfig()
    record, field = field_of(name, config)
    obj = Conditions() if record == "conditions" else getattr(config, record)
    return float(getattr(obj, field.name))
