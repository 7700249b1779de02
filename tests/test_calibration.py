"""The calibration against the paper's figures: driver, targets at the defaults, fit machinery, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from hev_thermal_env import paper_bus
from hev_thermal_env.calibration import fit as F
from hev_thermal_env.paper import measure as M
from hev_thermal_env.paper.figures import PAPER_FIGURE_BY_NAME
from hev_thermal_env.physics import ThermalParams, VehicleConfig

ROOT = Path(__file__).resolve().parents[1]
FITTED = ROOT / "docs" / "calibration" / "fitted_params.yaml"


def _run_strategy():
    from hev_thermal_env.evaluation.runner import run_strategy
    return run_strategy


@pytest.fixture(scope="module")
def measured():
    return M.measure(paper_bus(), hwfet=True)


@pytest.mark.parametrize("cycle", ["udds", "beijing"])
def test_light_driver_reproduces_the_environment_run(cycle):
    from hev_thermal_env.agents import get_strategy

    ref = _run_strategy()(get_strategy("rule"), cycle, "paper")
    _, tr = M.cycle_run(paper_bus(), cycle)
    for key in ("fuel_g", "motor_temp_c", "heat_x", "soc", "coolant_temp_c", "u"):
        np.testing.assert_array_equal(tr[key], ref.trace[key])


def test_defaults_hold_the_committed_fit():
    values = yaml.safe_load(FITTED.read_text())["thermal"]
    defaults = ThermalParams()
    assert set(values) == set(F.NETWORK_PARAMS + F.CLOSURE_PARAMS)
    for name, value in values.items():
        assert getattr(defaults, name) == value, name
    assert VehicleConfig.from_yaml(FITTED) == paper_bus()


def test_fitted_values_inside_their_documented_bounds():
    bounds = F.fitted_fields()
    assert set(bounds) == set(F.NETWORK_PARAMS + F.CLOSURE_PARAMS)
    for name, (lo, hi) in bounds.items():
        assert lo <= getattr(ThermalParams(), name) <= hi, name
        assert lo <= F.START[name] <= hi, name


# --- the paper's figures at the calibrated defaults ---------------------------------------------------------

def _within(measured, *names):
    """Every named figure within the paper's tolerance (the table's; ``test_paper_table`` pins the tolerances)."""
    return {n: measured["values"][n] for n in names if not PAPER_FIGURE_BY_NAME[n].within(measured["values"][n])}


def test_figs_7_8_udds(measured):
    assert not _within(measured, "udds_hi_onset_s", "udds_hi_peak", "udds_hi_return_s", "udds_temp_peak_c",
                       "udds_temp_last300_c")


def test_figs_9_10_beijing(measured):
    assert not _within(measured, "beijing_temp_c", "beijing_hi_peak")


def test_table2(measured):
    """Beijing unchanged; UDDS: the thermal model's cost on equal service (corrected fuel) is the paper's +0.3.

    The raw UDDS difference falls short of +0.3 ± 0.15 (docs/thermal_model.md): the rule strategy's SOC
    loop does not win back the extra battery energy within one cycle, and derated shortfalls become a
    priced trace miss, not engine fuel.
    """
    v = measured["values"]
    assert not _within(measured, "beijing_fuel_delta_l100")
    assert 0.0 < v["udds_fuel_delta_l100"] < 0.3
    corrected = measured["udds"]["fuel_corrected_l100"] - M.Baseline(paper_bus()).runs["udds"]["fuel_corrected_l100"]
    assert corrected == pytest.approx(0.3, abs=0.15)


def test_paper_equations_as_written_miss_figs_7_8():
    m = M.measure(paper_bus("paper_eqs"))
    assert m["values"]["udds_temp_peak_c"] < 36.0  # the coolant clamps the node at the thermostat
    assert m["values"]["udds_hi_peak"] < 0.07


# --- the fit machinery (tiny budget) and the command -----------------------------------------------------

def test_fit_machinery_stays_in_bounds_and_never_worsens():
    res = F.run_fit(seed=3, de_maxiter=1, de_popsize=1, polish_maxfev=8)
    bounds = F.fitted_fields()
    for name, value in res.values.items():
        lo, hi = bounds[name]
        assert lo <= value <= hi
        assert value == F.round_sig(value)
    for stage in res.stages:
        assert stage.cost <= stage.cost_start + 1e-12
    assert set(res.residuals) == {t.name for t in F.TARGETS}


def test_objective_rejects_invalid_combinations():
    obj = F.Objective(paper_bus(), ("t_gain_temp_lo_c", "t_gain_temp_hi_c"), {}, ["udds_temp_peak_c"],
                      baseline=None)
    assert obj([40.0, 30.0]) == 1e6  # hi below lo: ConfigError, not a run


def test_command_writes_parameters_and_residuals(tmp_path):
    from hev_thermal_env.calibration.__main__ import main

    assert main(["--out", str(tmp_path), "--no-fit", "--check", "--quiet"]) == 0
    values = yaml.safe_load((tmp_path / "fitted_params.yaml").read_text())["thermal"]
    assert values == yaml.safe_load(FITTED.read_text())["thermal"]
    data = json.loads((tmp_path / "residuals.json").read_text())
    assert data["n_targets"] == len(F.TARGETS) and data["met"] >= len(F.TARGETS) - 1
    md = (tmp_path / "residuals.md").read_text()
    assert "paper's eqs" in md and "not met" in md


def test_residual_definitions():
    t = PAPER_FIGURE_BY_NAME["udds_temp_peak_c"]
    assert t.residual(44.0) == 0.0 and t.within(45.9) and not t.within(46.1)
    one_sided = PAPER_FIGURE_BY_NAME["beijing_hi_peak"]
    assert one_sided.residual(0.0) == 0.0 and one_sided.within(0.05) and not one_sided.within(0.06)
    assert not t.within(float("nan")) and t.residual(float("inf")) == 10.0
    accel = PAPER_FIGURE_BY_NAME["accel_off_s"]  # ± 5 %: the residual in tolerances of 0.05 × 16.4 s
    assert accel.residual(16.4 + 0.41) == pytest.approx(0.5) and accel.residual(15.0) == (15.0 - 16.4) / (0.05 * 16.4)


def test_the_calibration_fits_a_subset_of_the_papers_figures():
    assert [t.name for t in F.TARGETS][:3] == ["udds_hi_onset_s", "udds_hi_peak", "udds_hi_return_s"]
    assert all(t is PAPER_FIGURE_BY_NAME[t.name] and t.judged for t in F.TARGETS)
    assert "top_speed_off_kmh" not in {t.name for t in F.TARGETS}  # held out: the thermal model cannot change it
