"""The calibration by the pre-registered protocol: the code's parameters against its YAML, the fit machinery on
problems with known answers, a reduced fit against the committed one, the fit log, the command and the page."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.stats import qmc

from hev_thermal_env import paper_bus
from hev_thermal_env.physics import Conditions, ThermalParams, VehicleConfig
from tools.calibration import docs, fit
from tools.calibration import protocol as proto
from tools.paper import measure
from tools.paper.figures import FITTED, HELD_OUT

ROOT = Path(__file__).resolve().parents[1]
CAL = ROOT / "docs" / "calibration"
COMMITTED = yaml.safe_load((CAL / "fitted_params.yaml").read_text())
ATTEMPTS = json.loads((CAL / "fit_result.json").read_text())
#: The reduced fit against the committed one: unit-box coordinates and Σr².
REFIT_TOL_UNIT, REFIT_TOL_COST, REFIT_BUDGET_S = 0.01, 0.05, 60.0


@pytest.mark.parametrize("cycle", ["udds", "beijing"])
def test_light_driver_reproduces_the_environment_run(cycle):
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.evaluation.runner import run_strategy

    ref = run_strategy(get_strategy("rule"), cycle, "paper")
    _, tr = measure.cycle_run(paper_bus(), cycle)
    for key in ("fuel_g", "motor_temp_c", "winding_temp_c", "heat_x", "soc", "coolant_temp_c", "u"):
        np.testing.assert_array_equal(tr[key], ref.trace[key])


# --- the code's parameters are the protocol's ---------------------------------------------------------------

def test_the_fitted_parameters_and_their_bounds_are_the_protocols():
    rows = proto.parameters()
    fitted = proto.fitted_parameters()
    assert [p.name for p in fitted] == [n for n, r in rows.items() if r["status"] == "fitted"] == ["t_gain_cold"]
    for p in fitted:
        r = rows[p.name]
        assert (p.lo, p.hi, p.start) == (r["min"], r["max"], r["value"])
        assert p.from_unit(0.0) == pytest.approx(p.lo, rel=1e-12) and p.from_unit(1.0) == pytest.approx(p.hi, rel=1e-12)
        assert p.from_unit(-0.5) == pytest.approx(p.lo) and p.from_unit(1.5) == pytest.approx(p.hi)  # clipped
        assert p.to_unit(p.from_unit(0.37)) == pytest.approx(0.37)
    assert [p.log for p in fitted] == [False]
    assert fitted[0].from_unit(0.5) == pytest.approx(0.2)  # linear scale: the range's midpoint
    rating = {n: r["value"] for n, r in rows.items() if n in ("jacket_ua_w_per_k", "radiator_ua_w_per_k")}
    assert rating == {"jacket_ua_w_per_k": 1281.9, "radiator_ua_w_per_k": 138.0}  # set by the rating, not fitted


def _derived(row: dict, rows: dict) -> float:
    names = {n: r["value"] for n, r in rows.items()}
    return float(eval(row["formula"], {"__builtins__": {}}, names))


def test_every_value_in_the_code_is_the_protocols():
    rows, th = proto.parameters(), ThermalParams()
    wrong = []
    for name, r in rows.items():
        if r["status"] == "derived":
            code = getattr(th, name)
            formula = _derived(r, rows)
            if not (math.isclose(code, r["value"], rel_tol=2e-3) and math.isclose(formula, code, rel_tol=1e-9)):
                wrong.append((name, code, r["value"]))
            continue
        code = proto.value_in_code(name)
        want = COMMITTED["thermal"][name] if r["status"] == "fitted" else r["value"]
        inside = r["min"] * (1 - 1e-6) <= code <= r["max"] * (1 + 1e-6)
        if not math.isclose(code, want, rel_tol=1e-6) or not inside:
            wrong.append((name, code, want))
    assert not wrong, f"parameter_ranges.yaml against the code (name, code, YAML/fit): {wrong}"


def test_no_bound_in_the_code_is_wider_than_the_physical_range():
    wider = []
    for name, r in proto.parameters().items():
        if r["status"] == "derived" or r["min"] == r["max"]:
            continue  # min = max: the paper's value; the field's spec is a validation range, not a fit bound
        _, field = proto.field_of(name)
        lo, hi = field.metadata.get("min"), field.metadata.get("max")
        if (lo is not None and lo < r["min"]) or (hi is not None and hi > r["max"]):
            wider.append((name, (lo, hi), (r["min"], r["max"])))
    assert not wider, f"spec bounds wider than parameter_ranges.yaml: {wider}"


def test_a_value_outside_the_protocol_is_reported_naming_the_row(tmp_path):
    text = proto.PROTOCOL_YAML.read_text().replace("value: 1281.9, min: 50.0", "value: 25.0, min: 50.0")
    bad = tmp_path / "ranges.yaml"
    bad.write_text(text)
    with pytest.raises(ValueError, match=r"jacket_ua_w_per_k.*value 25.0 is outside"):
        proto.load(bad)
    with pytest.raises(KeyError, match="no_such_parameter"):
        proto.field_of("no_such_parameter")


# --- the committed fit ------------------------------------------------------------------------------------

def test_the_committed_fit_is_the_adopted_attempt():
    meta, values = COMMITTED["fit"], COMMITTED["thermal"]
    adopted = [a for a in ATTEMPTS if a["adopted"]]
    assert len(adopted) == 1 and adopted[0] is ATTEMPTS[-1] and adopted[0]["label"] == meta["attempt"]
    assert meta["x_unit"] == adopted[0]["x"] and meta["cost"] == adopted[0]["cost"]
    starts = {p.name: p.start for p in proto.fitted_parameters()}
    for name, value in meta["fixed"].items():  # the fallback fixes a parameter at its documented start
        assert value == starts[name] == values[name]
    for name in meta["free"]:
        assert values[name] == fit.round_sig(adopted[0]["values"][name])
    for earlier in ATTEMPTS[:-1]:
        assert earlier["fallback"] and set(earlier["fallback"]) <= set(meta["fixed"])


def test_a_reduced_fit_reproduces_the_committed_one():
    """The adopted attempt's fit again from its winning start: a physics change that moves the fit fails here."""
    meta = COMMITTED["fit"]
    params = [p for p in proto.fitted_parameters() if p.name in meta["free"]]
    t0 = time.perf_counter()
    problem = fit.Problem(params, meta["fixed"])
    start = fit.fit_from(problem, "committed start", meta["start_unit"], fit.Settings(**meta["settings"]))
    wall = time.perf_counter() - t0
    print(f"reduced fit: {start.values} Σr² {start.cost:.4f} in {start.evaluations} runs, {wall:.1f} s "
          f"(committed {meta['x_unit']}, Σr² {meta['cost']:.4f})")
    assert np.abs(np.array(start.x) - meta["x_unit"]).max() <= REFIT_TOL_UNIT
    assert start.cost == pytest.approx(meta["cost"], abs=REFIT_TOL_COST)
    assert wall < REFIT_BUDGET_S


# --- the machinery on problems with known answers ---------------------------------------------------------

class Linear:
    """r(θ̃) = A·θ̃ − b, parameters on [0, 10] (linear), for the identifiability code."""

    def __init__(self, a, b):
        self.a, self.b = np.asarray(a, float), np.asarray(b, float)
        self.params = tuple(proto.FitParam(f"p{i}", 5.0, 0.0, 10.0, False) for i in range(self.a.shape[1]))
        self.targets = tuple(range(self.a.shape[0]))

    def residuals(self, x):
        return self.a @ np.asarray(x, float) - self.b

    def cost(self, x):
        return float(np.sum(self.residuals(x) ** 2))


def test_identifiability_of_a_linear_problem():
    a = np.array([[3.0, 0.0], [0.0, 0.1], [1.0, 1.0]])
    lin, x = Linear(a, [1.0, 0.0, 0.5]), np.array([0.3, 0.99])
    idf = fit.identifiability(lin, x, fit.Settings())
    np.testing.assert_allclose(idf["jacobian"], a, atol=1e-9)
    assert idf["steps"] == ["central", "backward"]  # 0.99 + 0.02 would leave the unit box
    sv = np.linalg.svd(a, compute_uv=False)
    np.testing.assert_allclose(idf["singular_values"], sv, rtol=1e-9)
    assert idf["condition_number"] == pytest.approx(sv[0] / sv[-1])
    se = np.sqrt(np.diag(np.linalg.inv(a.T @ a)))
    np.testing.assert_allclose(idf["se_unit"], se, rtol=1e-9)
    np.testing.assert_allclose(idf["se_physical"], 10.0 * se, rtol=1e-9)
    assert idf["distance_from_bounds"] == pytest.approx([0.3, 0.01]) and idf["near_bound"] == [False, True]
    ill = fit.identifiability(Linear([[3.0, 0.0], [0.0, 0.1]], [0, 0]), x, fit.Settings())
    assert set(fit.fallback_fixes(lin.params, ill, [], fit.Settings())) == {"p1"}  # 0.1 < 0.05 × 3


def test_profiles_find_a_flat_parameter_and_the_fallback_fixes_it():
    lin = Linear([[2.0, 0.0], [0.0, 0.0]], [1.0, 0.0])  # p1 never moves a residual
    x = np.array([0.5, 0.5])
    profs = fit.profiles(lin, x, fit.Settings(profile_points=11), lambda what, cost: None)
    assert [p["flat"] for p in profs] == [False, True]
    assert profs[0]["identified_low"] and profs[0]["identified_high"]
    assert profs[0]["delta"][0] == pytest.approx(1.0) and max(profs[1]["delta"]) == pytest.approx(0.0, abs=1e-12)
    idf = fit.identifiability(lin, x, fit.Settings())
    assert set(fit.fallback_fixes(lin.params, idf, profs, fit.Settings())) == {"p1"}
    flat_only = {**idf, "singular_values": [2.0, 1.0]}  # the profile rule alone
    assert "profile flat" in fit.fallback_fixes(lin.params, flat_only, profs, fit.Settings())["p1"]


def test_the_starts_are_the_documented_one_and_eight_sobol_points():
    params = proto.fitted_parameters()
    starts = fit.start_points(params, fit.Settings())
    assert [s[0] for s in starts] == ["documented"] + [f"sobol {i}" for i in range(1, 9)]
    np.testing.assert_allclose(starts[0][1], [p.to_unit(p.start) for p in params])
    np.testing.assert_array_equal(np.array([s[1] for s in starts[1:]]),
                                  qmc.Sobol(d=1, scramble=True, seed=23).random(8))


# --- the fit log, the command, the page -------------------------------------------------------------------

def test_the_fit_log_records_every_attempt():
    text = (CAL / "fit_log.md").read_text()
    entries = text.split("\n## Attempt ")[1:]
    assert len(entries) >= len(ATTEMPTS)
    for entry, attempt in zip(entries[-len(ATTEMPTS):], ATTEMPTS):
        for needed in ("Date ", "commit `", "protocol commit `", "Settings: least_squares trf", "Starts (",
                       "distance from bounds", "wall time", *(f"| {t.id} |" for t in FITTED + HELD_OUT)):
            assert needed in entry, needed
        assert attempt["label"] in entry.splitlines()[0]
        assert ("(**adopted**)" in entry.splitlines()[0]) == attempt["adopted"]
        if attempt["free"]:
            assert "Singular values of ∂r/∂θ̃: " + ", ".join(
                f"{s:.4g}" for s in attempt["identifiability"]["singular_values"]) in entry


def test_command_writes_the_residuals_and_checks_the_defaults(tmp_path):
    from tools.calibration.__main__ import main

    shutil.copy(CAL / "fitted_params.yaml", tmp_path)
    assert main(["--out", str(tmp_path), "--report-only", "--check", "--quiet"]) == 0
    md = (tmp_path / "residuals.md").read_text()
    assert all(f"| {t.id} | " in md for t in FITTED + HELD_OUT) and "paper's eqs" in md
    assert md == (CAL / "residuals.md").read_text()  # the committed table is the code's
    data = yaml.safe_load((tmp_path / "fitted_params.yaml").read_text())
    data["thermal"]["t_gain_cold"] = 0.25
    (tmp_path / "fitted_params.yaml").write_text(yaml.safe_dump(data))
    assert main(["--out", str(tmp_path), "--report-only", "--check", "--quiet"]) == 1


def test_the_thermal_model_page_holds_what_the_code_gives():
    page, generated = docs.page_blocks(), docs.generated()
    assert set(page) == set(docs.BLOCKS)
    for name, lines in generated.items():
        assert page[name] == "\n".join(lines), f"docs/thermal_model.md block {name!r}: run " \
                                                "python -m tools.calibration --report-only --write-docs"


def test_with_values_sets_the_protocols_names_on_their_records():
    cfg = proto.with_values(paper_bus(), {"jacket_ua_w_per_k": 400.0, "motor_mass_kg": 90.0,
                                          "coulombic_efficiency": 0.96})
    assert (cfg.thermal.jacket_ua_w_per_k, cfg.thermal.mass_kg, cfg.battery.coulombic_efficiency) == (400, 90, 0.96)
    assert dataclasses.replace(cfg.thermal, jacket_ua_w_per_k=1281.9, mass_kg=100.0) == paper_bus().thermal
    with pytest.raises(ValueError, match="condition"):
        proto.with_values(paper_bus(), {"accessory_power_w": 0.0})
    assert isinstance(cfg, VehicleConfig) and proto.value_in_code("accessory_power_w") == Conditions().accessory_power_w
