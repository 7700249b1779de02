"""Loading cycles: built-in names, user CSV files and arrays.

Built-in cycles live in ``hev_thermal_env/cycles/data/`` as CSV files ``time_s,speed_mps,grade``. ``hwfet``,
``udds``, ``us06`` and ``wltc_3b`` are standard cycles vendored from the ``fastsim==2.1.5`` wheel (Apache-2.0, see
``data/README.md`` and ``data/NOTICE``); ``sort1``-``sort3`` (UITP's bus test cycles) and ``urban_bus`` (an 8,130 s
urban bus route with its grades) from the ``carculator-utils==1.3.5`` wheel (BSD-3-Clause,
``data/LICENSE-carculator-utils``). ``beijing`` is synthetic: the output of
:func:`~hev_thermal_env.cycles.generator.generate_bus_cycle` with a fixed seed, stored as CSV so it never depends on
the numpy version.

User CSV files have a header row naming the columns (case-insensitive; other columns are ignored): ``time_s`` and
``speed_mps`` are required, ``grade`` (rise/run) defaults to 0. Blank lines and lines starting with ``#`` are
skipped. Time must increase with a uniform step; it is shifted to 0 s and resampled to 1 s
(:func:`~hev_thermal_env.cycles.cycle.to_1s_grid`). Errors raise ``ValueError`` naming the file, the position as
``data row N (line M)`` and the problem. Data implausible for a bus gives an
:class:`~hev_thermal_env.cycles.cycle.ImplausibleCycleWarning` (not for the built-in cycles: ``us06`` and ``wltc_3b``
are car cycles above a bus's top speed).
"""

from __future__ import annotations

import csv
import functools
import io
import os
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .cycle import Cycle, Locate, float_vector, to_1s_grid
from .generator import BEIJING_KWARGS, BEIJING_SEED, BEIJING_TARGETS, bus_cycle_params
from .names import generated_cycle

#: The packages built-in cycles are vendored from: package -> (licence, source text with ``{where}``).
_PACKAGES: dict[str, tuple[str, str]] = {
    "fastsim==2.1.5": ("Apache-2.0", "fastsim==2.1.5 wheel from PyPI, fastsim/resources/cycles/{where} (Apache-2.0, "
                       "Alliance for Sustainable Energy, LLC); converted to time_s,speed_mps,grade without changing "
                       "values"),
    "carculator-utils==1.3.5": ("BSD-3-Clause", "carculator-utils==1.3.5 wheel from PyPI, "
                                "carculator_utils/data/{where} (BSD-3-Clause, Paul Scherrer Institut); km/h converted "
                                "to m/s"),
}

#: Built-in cycles: name -> (description, package, where in it; both None for the synthetic ``beijing``).
_BUILTINS: dict[str, tuple[str, str | None, str | None]] = {
    "hwfet": ("EPA Highway Fuel Economy Test cycle (HWFET)", "fastsim==2.1.5", "hwfet.csv"),
    "udds": ("EPA Urban Dynamometer Driving Schedule (UDDS, FTP-72)", "fastsim==2.1.5", "udds.csv"),
    "us06": ("EPA US06 Supplemental FTP cycle (aggressive driving)", "fastsim==2.1.5", "us06.csv"),
    "wltc_3b": ("WLTC class 3b (WLTP, four phases: low, medium, high, extra high)", "fastsim==2.1.5", "wltc_3b.csv"),
    "beijing": ("Synthetic Beijing-like city-bus cycle (generated, not measured)", None, None),
    "sort1": ("UITP SORT 1 bus test cycle (heavy urban)", "carculator-utils==1.3.5",
              "driving_cycles/car.csv, column 'SORT 1'"),
    "sort2": ("UITP SORT 2 bus test cycle (easy urban)", "carculator-utils==1.3.5",
              "driving_cycles/car.csv, column 'SORT 2'"),
    "sort3": ("UITP SORT 3 bus test cycle (suburban)", "carculator-utils==1.3.5",
              "driving_cycles/car.csv, column 'SORT 3'"),
    "urban_bus": ("Urban bus route of a 13 m bus, 8,130 s with its grades", "carculator-utils==1.3.5",
                  "driving_cycles/bus.csv and gradient/bus.csv, column 'Urban, 13m' (its gradient angle as "
                  "rise/run)"),
}

_REQUIRED = ("time_s", "speed_mps")
_OPTIONAL = ("grade",)


def list_cycles() -> list[str]:
    """Names of the built-in cycles: ``["hwfet", "udds", "us06", "wltc_3b", "beijing", "sort1", "sort2", "sort3",
    "urban_bus"]``."""
    return list(_BUILTINS)


@functools.cache
def _builtin_arrays(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    origin = f"built-in cycle file {name}.csv"
    text = resources.files(__package__).joinpath("data", f"{name}.csv").read_text("utf-8")
    *arrays, where = _read_csv(text, origin=origin)
    *arrays, _ = to_1s_grid(*arrays, origin=origin, locate=where, plausibility=False)
    for arr in arrays:
        arr.flags.writeable = False
    return tuple(arrays)


def _load_builtin(name: str) -> Cycle:
    time_s, speed_mps, grade = _builtin_arrays(name)
    description, package, where = _BUILTINS[name]
    if package is not None:
        licence, source = _PACKAGES[package]
        source = source.format(where=where)
        metadata: dict[str, Any] = {"synthetic": False, "package": package, "license": licence}
    else:
        args = ", ".join([f"seed={BEIJING_SEED}"] + [f"{k}={v!r}" for k, v in BEIJING_KWARGS.items()])
        source = f"hev_thermal_env.cycles.generate_bus_cycle({args}), stored as data/{name}.csv"
        metadata = {"synthetic": True, "note": "synthetic: generated by a stop-to-stop micro-trip model, not measured",
                    "generator": "hev_thermal_env.cycles.generate_bus_cycle", "seed": BEIJING_SEED,
                    "params": bus_cycle_params(**BEIJING_KWARGS),
                    "targets": {k: list(v) for k, v in BEIJING_TARGETS.items()}}
    return Cycle(name=name, time_s=time_s, speed_mps=speed_mps, grade=grade, synthetic=metadata["synthetic"],
                 description=description, source=source, metadata=metadata)


def _read_csv(text: str, *, origin: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, Locate]:
    """The ``time_s``, ``speed_mps`` and ``grade`` columns of CSV text, and the locator of its data rows (blank and
    ``#`` lines skipped)."""
    reader = csv.reader(io.StringIO(text.removeprefix("\ufeff")))
    rows = [(line_no, fields) for line_no, fields in enumerate(reader, start=1)
            if fields and any(f.strip() for f in fields) and not fields[0].lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{origin}: file is empty (no header and no data rows)")
    (header_line, header), *data = rows
    columns: dict[str, int] = {}
    for j, col in enumerate(h.strip().lower() for h in header):
        if col in _REQUIRED + _OPTIONAL:
            if col in columns:
                raise ValueError(f"{origin}: line {header_line}: duplicate column {col!r}")
            columns[col] = j
    for col in _REQUIRED:
        if col not in columns:
            found = ", ".join(repr(h.strip()) for h in header)
            raise ValueError(f"{origin}: line {header_line} (header): missing required column {col!r}; "
                             f"columns found: {found}; expected time_s, speed_mps and optional grade")
    if not data:
        raise ValueError(f"{origin}: no data rows after the header (line {header_line})")

    def where(i: int) -> str:
        return f"data row {i + 1} (line {data[i][0]})"
    values = {c: np.empty(len(data)) for c in _REQUIRED + _OPTIONAL if c in columns}
    for i, (_, fields) in enumerate(data):
        for col, arr in values.items():
            raw = fields[columns[col]].strip() if columns[col] < len(fields) else ""
            if not raw:
                raise ValueError(f"{origin}: {where(i)}: missing value in column {col!r}")
            try:
                arr[i] = float(raw)
            except ValueError:
                raise ValueError(f"{origin}: {where(i)}: non-numeric value {raw!r} in column {col!r}") from None
    return values["time_s"], values["speed_mps"], values.get("grade", np.zeros(len(data))), where


def _load_csv(path: Path) -> Cycle:
    origin = f"cycle file '{path}'"
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{origin}: not a UTF-8 text file ({exc.reason})") from None
    *arrays, where = _read_csv(text, origin=origin)
    time_s, speed_mps, grade, info = to_1s_grid(*arrays, origin=origin, locate=where)
    description = f"User cycle from {path.name}"
    if info["resampled"]:
        description += f" (resampled from {info['original_time_step_s']:g} s to 1 s)"
    return Cycle(name=path.stem, time_s=time_s, speed_mps=speed_mps, grade=grade, synthetic=False,
                 description=description, source=str(path), metadata={"path": str(path), **info})


def load_cycle(name_or_path: str | os.PathLike | Cycle) -> Cycle:
    """The cycle named by a built-in name from :func:`list_cycles` (case-insensitive), a generated cycle's name
    (``FAMILY:SEED`` or ``validation_bus:K``, :mod:`~hev_thermal_env.cycles.names`), either followed by ``*K``
    (:func:`laps`: K laps back to back, a service day's repetition, e.g. ``udds*3``) or a CSV path (module
    docstring); a :class:`Cycle` is returned unchanged.

    Raises ``ValueError`` if the name is neither built-in, nor a generated cycle's, nor an existing file (the
    message lists the built-in names), if it names a family or a set rather than one cycle, or if the file is
    invalid; ``TypeError`` for another type.
    """
    if isinstance(name_or_path, Cycle):
        return name_or_path
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise TypeError(f"expected a cycle name, a path or a Cycle, got {type(name_or_path).__name__}")
    if isinstance(name_or_path, str) and name_or_path.strip().lower() in _BUILTINS:
        return _load_builtin(name_or_path.strip().lower())
    if isinstance(name_or_path, str) and not Path(name_or_path).is_file():
        if (lapped := _LAPS.match(name_or_path.strip())) is not None:
            return laps(load_cycle(lapped.group(1)), int(lapped.group(2)))
        if (generated := generated_cycle(name_or_path)) is not None:
            return generated
    path = Path(name_or_path)
    if path.is_file():
        return _load_csv(path)
    if path.is_dir():
        raise ValueError(f"cycle file '{path}': is a directory, expected a CSV file")
    raise ValueError(
        f"unknown cycle {str(name_or_path)!r}: not a built-in name and not an existing file; "
        f"built-in cycles: {', '.join(list_cycles())}. "
        "Generated bus cycles: FAMILY:SEED (families: random_bus, bus_long, bus_congested, bus_launch, "
        "bus_hilly, bus_mixed, bus_express) and validation_bus:K; generate_bus_cycle(seed) in Python."
    )


_LAPS = re.compile(r"^(.+)\*(\d+)$")


def laps(cycle: Cycle, k: int) -> Cycle:
    """``k`` laps of ``cycle`` back to back (each lap's last second is the next one's first), named ``NAME*k``."""
    if k < 1:
        raise ValueError(f"laps: {cycle.name}*{k}: the number of laps must be at least 1")
    speed, grade = np.asarray(cycle.speed_mps), np.asarray(cycle.grade)
    return cycle_from_arrays(np.concatenate([speed[:-1]] * (k - 1) + [speed]),
                             np.concatenate([grade[:-1]] * (k - 1) + [grade]), name=f"{cycle.name}*{k}",
                             description=f"{k} laps of {cycle.name}", source=cycle.source,
                             synthetic=cycle.synthetic, metadata={"laps": k, "lap": cycle.name})


def cycle_from_arrays(speed_mps: Any, grade: Any = None, name: str = "custom", *, time_s: Any = None,
                      description: str = "", source: str = "arrays", synthetic: bool = False,
                      metadata: dict | None = None) -> Cycle:
    """A validated :class:`Cycle` from ``speed_mps`` [m/s] and ``grade`` (rise/run, zeros if omitted).

    ``time_s`` (default ``0, 1, 2, ...``) is shifted to 0 s and resampled to 1 s as for CSV files; the original
    time step and offset are added to ``metadata``. Raises ``ValueError`` with the sample index and the problem for
    the same faults as CSV files (non-numeric, NaN/inf, negative speed, non-increasing or non-uniform time, length
    mismatch, fewer than 2 samples).
    """
    origin = f"cycle_from_arrays({name!r})"
    speed = float_vector("speed_mps", speed_mps, origin)
    grd = np.zeros(len(speed)) if grade is None else float_vector("grade", grade, origin)
    t = np.arange(len(speed), dtype=np.float64) if time_s is None else float_vector("time_s", time_s, origin)
    t, speed, grd, info = to_1s_grid(t, speed, grd, origin=origin)
    return Cycle(name=name, time_s=t, speed_mps=speed, grade=grd, synthetic=synthetic, description=description,
                 source=source, metadata={**(metadata or {}), **info})
