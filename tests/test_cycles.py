"""Tests of the drive-cycle module: built-in cycles, the synthetic bus generator, CSV loading."""

from __future__ import annotations

import dataclasses
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hev_thermal_env.cycles
from hev_thermal_env.cycles import (
    Cycle,
    cycle_from_arrays,
    generate_bus_cycle,
    list_cycles,
    load_cycle,
)
from hev_thermal_env.cycles.generator import BEIJING_KWARGS, BEIJING_SEED, BEIJING_TARGETS

# name: (duration_s, distance_km, distance tolerance_km)
STANDARD_CYCLES = {
    "hwfet": (765.0, 16.51, 0.05),
    "udds": (1369.0, 11.99, 0.05),
    "us06": (600.0, 12.89, 0.05),
    "wltc_3b": (1800.0, 23.27, 0.05),
}


# -- built-in cycles ---------------------------------------------------------------------


# name: (duration_s, distance_km, max speed km/h), from the carculator-utils wheel's columns (data/README.md)
BUS_CYCLES = {
    "sort1": (152.0, 0.519, 40.0),
    "sort2": (182.0, 0.938, 50.0),
    "sort3": (225.0, 1.457, 60.0),
    "urban_bus": (8130.0, 39.550, 68.1),
}


def test_list_cycles():
    assert list_cycles() == ["hwfet", "udds", "us06", "wltc_3b", "beijing", "sort1", "sort2", "sort3", "urban_bus"]


@pytest.mark.parametrize("name", list(BUS_CYCLES))
def test_vendored_bus_cycles(name):
    duration_s, distance_km, max_kmh = BUS_CYCLES[name]
    cyc = load_cycle(name)
    assert (cyc.duration_s, cyc.n_steps) == (duration_s, int(duration_s))
    assert cyc.distance_km == pytest.approx(distance_km, abs=0.001)
    assert cyc.max_speed_kmh == pytest.approx(max_kmh, abs=1e-6)  # km/h / 3.6 written to 10 significant digits
    assert not cyc.synthetic and cyc.metadata["license"] == "BSD-3-Clause"
    assert "carculator-utils==1.3.5" in cyc.source
    assert cyc.speed_mps[0] == 0.0 and cyc.speed_mps[-1] == 0.0 and cyc.speed_mps.max() > 0.0


def test_the_bus_cycles_licence_is_vendored():
    licence = Path(hev_thermal_env.cycles.__file__).parent / "data" / "LICENSE-carculator-utils"
    assert "Paul Scherrer Institut" in licence.read_text() and "BSD 3-Clause" in licence.read_text()


def test_urban_bus_route_has_grades_and_no_net_climb():
    cyc = load_cycle("urban_bus")
    assert cyc.grade.min() == pytest.approx(-0.0748, abs=1e-4) and cyc.grade.max() == pytest.approx(0.0889, abs=1e-4)
    mean_speed = 0.5 * (cyc.speed_mps[:-1] + cyc.speed_mps[1:])
    assert abs(float(np.sum(cyc.grade[:-1] * mean_speed))) < 1.0  # metres climbed over 39.55 km
    assert cyc.idle_fraction == pytest.approx(0.335, abs=0.001)
    assert np.all(load_cycle("sort1").grade == 0.0)
    assert np.count_nonzero(load_cycle("sort1").speed_mps[-20:]) == 0  # the closing stop the column holds


@pytest.mark.parametrize("name", list(STANDARD_CYCLES))
def test_standard_cycle_duration_and_distance(name):
    duration_s, distance_km, tol_km = STANDARD_CYCLES[name]
    cyc = load_cycle(name)
    assert cyc.name == name
    assert cyc.duration_s == duration_s
    assert cyc.n_steps == int(duration_s)
    assert cyc.distance_km == pytest.approx(distance_km, abs=tol_km)
    assert cyc.mean_speed_kmh == pytest.approx(3.6 * cyc.distance_m / duration_s)
    assert not cyc.synthetic
    assert "fastsim==2.1.5" in cyc.source
    assert cyc.speed_mps[0] == 0.0 and cyc.speed_mps[-1] == 0.0


def test_standard_cycle_known_features():
    assert load_cycle("hwfet").max_speed_kmh == pytest.approx(96.4, abs=0.1)
    assert load_cycle("udds").max_speed_kmh == pytest.approx(91.25, abs=0.1)
    assert load_cycle("us06").max_speed_kmh == pytest.approx(129.2, abs=0.1)
    assert load_cycle("wltc_3b").max_speed_kmh == pytest.approx(131.3, abs=0.01)
    assert load_cycle("udds").idle_fraction == pytest.approx(0.191, abs=0.002)


@pytest.mark.parametrize("name", list_cycles())
def test_builtin_arrays_are_readonly_float64_on_1s_grid(name):
    cyc = load_cycle(name)
    for arr in (cyc.time_s, cyc.speed_mps, cyc.grade):
        assert arr.dtype == np.float64
        assert not arr.flags.writeable
        assert arr.shape == cyc.time_s.shape
    np.testing.assert_array_equal(cyc.time_s, np.arange(cyc.n_steps + 1))
    assert np.all(cyc.speed_mps >= 0)
    with pytest.raises(ValueError):
        cyc.speed_mps[0] = 1.0


def test_builtin_names_are_case_insensitive():
    assert load_cycle("HWFET").name == "hwfet"
    assert load_cycle(" Wltc_3B ").duration_s == 1800.0


def test_cycle_is_frozen():
    cyc = load_cycle("udds")
    with pytest.raises(AttributeError):
        cyc.name = "other"


# -- synthetic beijing cycle and generator ---------------------------------------------


def test_beijing_meets_targets():
    cyc = load_cycle("beijing")
    assert cyc.synthetic is True
    assert "synthetic" in cyc.description.lower()
    assert "not measured" in cyc.description
    assert cyc.metadata["synthetic"] is True
    assert cyc.metadata["seed"] == BEIJING_SEED
    assert "params" in cyc.metadata
    assert 1235.0 <= cyc.duration_s <= 1365.0  # 1300 s +- 5 %
    assert 14.0 <= cyc.mean_speed_kmh <= 18.0
    assert 55.0 <= cyc.max_speed_kmh <= 62.0
    assert 0.25 <= cyc.idle_fraction <= 0.30
    assert cyc.max_abs_accel_mps2 <= 1.1
    assert cyc.speed_mps[-1] == 0.0
    for key, (lo, hi) in BEIJING_TARGETS.items():
        assert lo <= getattr(cyc, key) <= hi, key


def test_beijing_file_is_reproduced_by_generator():
    stored = load_cycle("beijing")
    generated = generate_bus_cycle(BEIJING_SEED, **BEIJING_KWARGS)
    assert generated.synthetic
    assert len(generated.speed_mps) == len(stored.speed_mps)
    np.testing.assert_allclose(generated.speed_mps, stored.speed_mps, rtol=0, atol=1e-9)
    np.testing.assert_allclose(generated.grade, stored.grade, rtol=0, atol=1e-9)


def test_generator_is_deterministic():
    a = generate_bus_cycle(7)
    b = generate_bus_cycle(7)
    c = generate_bus_cycle(8)
    np.testing.assert_array_equal(a.speed_mps, b.speed_mps)
    assert a.speed_mps.shape != c.speed_mps.shape or not np.array_equal(a.speed_mps, c.speed_mps)
    assert a.metadata["seed"] == 7 and a.metadata["synthetic"] is True
    assert a.metadata["params"]["max_speed_kmh"] == 60.0


@pytest.mark.parametrize("seed", range(21))
def test_generator_random_seeds_give_valid_cycles(seed):
    cyc = generate_bus_cycle(seed)
    assert cyc.synthetic
    assert cyc.duration_s == 1300.0
    assert np.all(cyc.speed_mps >= 0.0)
    assert cyc.max_abs_accel_mps2 <= 1.1
    assert cyc.max_speed_kmh <= 60.0 + 1e-3
    assert cyc.speed_mps[0] == 0.0 and cyc.speed_mps[-1] == 0.0
    assert 0.0 < cyc.idle_fraction < 1.0
    assert cyc.distance_km > 0.0
    # limited jerk: only the landing step of a speed approach may exceed 0.5 m/s^3 a little
    assert np.max(np.abs(np.diff(cyc.accel_mps2))) <= 1.0


def test_generator_respects_duration_and_max_speed_arguments():
    cyc = generate_bus_cycle(3, 600.4, max_speed_kmh=40.0, cruise_speed_kmh_range=(10.0, 40.0))
    assert cyc.duration_s == 600.0
    assert cyc.max_speed_kmh <= 40.0 + 1e-3
    assert cyc.speed_mps[-1] == 0.0


def test_generator_rejects_bad_parameters():
    with pytest.raises(ValueError, match="duration_s"):
        generate_bus_cycle(0, duration_s=10.0)
    with pytest.raises(ValueError, match="cruise_speed_kmh_range"):
        generate_bus_cycle(0, max_speed_kmh=30.0)
    with pytest.raises(TypeError, match="seed"):
        generate_bus_cycle(1.5)


def test_random_bus_is_not_a_cycle_name():
    with pytest.raises(ValueError, match="generate_bus_cycle"):
        load_cycle("random_bus")


# -- loading by path, by Cycle, from arrays ----------------------------------------------


def test_load_by_cycle_instance_returns_it():
    cyc = load_cycle("us06")
    assert load_cycle(cyc) is cyc


def test_load_by_path_round_trip(tmp_path):
    cyc = load_cycle("beijing")
    path = cyc.to_csv(tmp_path / "bus.csv")
    assert path.read_text().splitlines()[0] == "time_s,speed_mps,grade"
    for arg in (path, str(path)):
        again = load_cycle(arg)
        assert again.name == "bus"
        assert not again.synthetic
        np.testing.assert_array_equal(again.speed_mps, cyc.speed_mps)
        np.testing.assert_array_equal(again.time_s, cyc.time_s)


def test_load_csv_without_grade_shifted_time(tmp_path):
    path = tmp_path / "short.csv"
    path.write_text("# my cycle\nSpeed_MPS,time_s,extra\n0,10,a\n1.5,11,b\n3,12,c\n0,13,d\n\n")
    cyc = load_cycle(path)
    np.testing.assert_array_equal(cyc.time_s, [0, 1, 2, 3])
    np.testing.assert_array_equal(cyc.speed_mps, [0, 1.5, 3, 0])
    np.testing.assert_array_equal(cyc.grade, np.zeros(4))
    assert cyc.metadata["time_offset_s"] == 10.0
    assert cyc.metadata["resampled"] is False


def test_resample_half_second_csv_to_1s(tmp_path):
    t = np.arange(0, 10.5, 0.5)  # 0 .. 10 s at 0.5 s
    v = 2.0 * t  # ramp: 2 m/s per s
    g = 0.001 * t
    path = tmp_path / "half.csv"
    rows = "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, v, g))
    path.write_text("time_s,speed_mps,grade\n" + rows + "\n")
    cyc = load_cycle(path)
    np.testing.assert_array_equal(cyc.time_s, np.arange(11.0))
    np.testing.assert_allclose(cyc.speed_mps, 2.0 * np.arange(11.0))
    np.testing.assert_allclose(cyc.grade, 0.001 * np.arange(11.0))
    assert cyc.metadata["resampled"] is True
    assert cyc.metadata["original_time_step_s"] == 0.5
    assert "resampled" in cyc.description


def test_resample_two_second_step_interpolates():
    cyc = cycle_from_arrays([0.0, 4.0, 0.0], time_s=[0.0, 2.0, 4.0])
    np.testing.assert_allclose(cyc.speed_mps, [0, 2, 4, 2, 0])


def test_cycle_from_arrays():
    cyc = cycle_from_arrays([0, 1, 2, 1, 0], grade=[0, 0.01, 0.02, 0.01, 0], name="tiny")
    assert cyc.name == "tiny"
    assert cyc.duration_s == 4.0
    assert cyc.distance_m == pytest.approx(4.0)
    assert cyc.max_abs_accel_mps2 == pytest.approx(1.0)
    assert cyc.idle_fraction == pytest.approx(0.4)
    assert cyc.mean_speed_kmh == pytest.approx(3.6)
    assert not cyc.time_s.flags.writeable


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"speed_mps": [0, -1, 0]}, "index 1: negative speed"),
        ({"speed_mps": [0, np.nan, 0]}, "index 1: speed_mps value nan is not finite"),
        ({"speed_mps": [0, "x", 0]}, "index 1: non-numeric value 'x'"),
        ({"speed_mps": [0, 1], "grade": [0]}, "length mismatch"),
        ({"speed_mps": [0]}, "at least 2 samples"),
        ({"speed_mps": [0, 1, 0], "time_s": [0, 1, 1]}, "index 2: time not increasing"),
        ({"speed_mps": [0, 1, 0], "time_s": [0, 1, 3]}, "index 2: non-uniform time step"),
        ({"speed_mps": [0, 1, 0], "grade": [0, 4, 0]}, "index 1: grade = 4.0"),
    ],
)
def test_cycle_from_arrays_rejects_bad_input(kwargs, message):
    with pytest.raises(ValueError, match="cycle_from_arrays") as info:
        cycle_from_arrays(**kwargs)
    assert message in str(info.value)


def test_cycle_constructor_requires_1s_grid():
    with pytest.raises(ValueError, match="0, 1, 2"):
        Cycle("x", np.array([0.0, 2.0]), np.zeros(2), np.zeros(2), False, "", "", {})


# -- bad CSV files ----------------------------------------------------------------------


def _write(tmp_path: Path, text: str, name: str = "bad_cycle.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "position", "problem"),
    [
        ("", None, "file is empty"),
        ("\n\n", None, "file is empty"),
        ("time_s,speed_mps,grade\n", "line 1", "no data rows"),
        ("time_s,grade\n0,0\n1,0\n", "line 1", "missing required column 'speed_mps'"),
        (
            "time_s,speed_mps\n0,0\n1,nan\n2,0\n",
            "data row 2 (line 3)",
            "speed_mps value nan is not finite",
        ),
        (
            "time_s,speed_mps\n0,0\n1,inf\n2,0\n",
            "data row 2 (line 3)",
            "not finite",
        ),
        (
            "time_s,speed_mps\n0,0\n1,2\n2,-0.5\n",
            "data row 3 (line 4)",
            "negative speed",
        ),
        (
            "time_s,speed_mps\n0,0\n1,2\n1,3\n3,0\n",
            "data row 3 (line 4)",
            "time not increasing",
        ),
        (
            "time_s,speed_mps\n0,0\n1,2\n0.5,3\n",
            "data row 3 (line 4)",
            "time not increasing",
        ),
        (
            "time_s,speed_mps\n0,0\n1,2\n2,3\n4,0\n",
            "data row 4 (line 5)",
            "non-uniform time step",
        ),
        (
            "time_s,speed_mps\n0,0\n1,fast\n2,0\n",
            "data row 2 (line 3)",
            "non-numeric value 'fast' in column 'speed_mps'",
        ),
        (
            "time_s,speed_mps\n0,0\n1\n2,0\n",
            "data row 2 (line 3)",
            "missing value in column 'speed_mps'",
        ),
        (
            "time_s,speed_mps,grade\n0,0,0\n1,2,5\n",
            "data row 2 (line 3)",
            "not a plausible rise/run fraction",
        ),
        ("time_s,speed_mps\n0,0\n", None, "at least 2 samples"),
    ],
)
def test_bad_csv_raises_with_file_row_and_problem(tmp_path, text, position, problem):
    path = _write(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_cycle(path)
    message = str(info.value)
    assert "bad_cycle.csv" in message
    assert problem in message
    if position is not None:
        assert position in message


def test_missing_column_lists_columns_found(tmp_path):
    path = _write(tmp_path, "cycSecs,cycMps\n0,0\n1,0\n")
    with pytest.raises(ValueError) as info:
        load_cycle(path)
    message = str(info.value)
    assert "missing required column 'time_s'" in message
    assert "'cycSecs', 'cycMps'" in message


def test_unknown_name_lists_known_names():
    with pytest.raises(ValueError) as info:
        load_cycle("nedc")
    message = str(info.value)
    assert "'nedc'" in message
    for name in list_cycles():
        assert name in message


def test_missing_file_is_unknown_name(tmp_path):
    with pytest.raises(ValueError, match="built-in cycles: hwfet"):
        load_cycle(tmp_path / "nope.csv")


def test_load_cycle_rejects_other_types():
    with pytest.raises(TypeError):
        load_cycle(42)


# -- property: CSV round trip -------------------------------------------------------------


@pytest.mark.filterwarnings("ignore::hev_thermal_env.cycles.ImplausibleCycleWarning")  # speeds to 60 m/s
@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.floats(min_value=0.0, max_value=60.0, allow_nan=False, allow_subnormal=False),
        min_size=2,
        max_size=40,
    )
)
def test_csv_round_trip_is_exact(speeds):
    cyc = cycle_from_arrays(speeds, name="prop")
    with tempfile.TemporaryDirectory() as tmp:
        again = load_cycle(cyc.to_csv(os.path.join(tmp, "prop.csv")))
    np.testing.assert_array_equal(again.speed_mps, cyc.speed_mps)
    assert again.distance_m == cyc.distance_m


def test_a_named_generated_cycle_is_generated_once_and_read_only():
    """Checking a training config loads every cycle it names; a named generated cycle (FAMILY:SEED,
    validation_bus:K) is generated once per process and shared, which is safe because a Cycle cannot change."""
    from hev_thermal_env import load_cycle

    for name in ("validation_bus:3", "bus_long:11"):
        first = load_cycle(name)
        assert load_cycle(name) is first and load_cycle(name.upper()) is first
        with pytest.raises(ValueError):
            first.speed_mps[0] = 1.0
        with pytest.raises(dataclasses.FrozenInstanceError):
            first.name = "other"
