"""The energy audit (defect d): it passes on every consistent run and fails when one component is changed alone."""

from __future__ import annotations

import numpy as np
import pytest

from hev_thermal_env import Conditions, cycle_from_arrays, load_cycle, paper_bus, simulate
from tools.audit import energy_audit, energy_balance


@pytest.fixture(scope="module")
def hilly_udds():
    cyc = load_cycle("udds")
    x = np.cumsum(cyc.speed_mps)
    return cycle_from_arrays(cyc.speed_mps, 0.04 * np.sin(x / 400.0), name="udds_hilly")


@pytest.mark.parametrize("model", ["network", "paper_eqs"])
@pytest.mark.parametrize("cycle, split, cond", [
    ("udds", 0.3, Conditions()),
    ("hwfet", -0.2, Conditions(ambient_temp_c=38.0, initial_motor_temp_c=38.0)),
    ("us06", 0.8, Conditions(payload_kg=4000.0, coolant="off", initial_motor_temp_c=60.0)),
    ("beijing", 1.0, Conditions(coolant="degraded", coolant_degraded_factor=0.05, fan=False, initial_soc=0.45)),
])
def test_audit_passes_on_consistent_runs(model, cycle, split, cond):
    cfg = paper_bus(model)
    res = simulate(cycle, cfg, split, cond)
    audit = energy_audit(res.trace, cfg, cycle, cond)
    assert audit.ok, audit.summary()


def test_audit_passes_on_grades(hilly_udds):
    cfg = paper_bus()
    res = simulate(hilly_udds, cfg, 0.5)
    assert energy_audit(res.trace, cfg, hilly_udds).ok


def _run(cfg, cycle="udds", split=0.4, cond=None):
    return simulate(cycle, cfg, split, cond).trace


def test_fuel_map_changed_in_the_run_only_fails_the_audit_not_the_old_balance():
    declared = paper_bus()
    c = np.array(declared.engine.fuel_coeffs)
    ran = declared.replace(engine=declared.engine.replace(fuel_coeffs=tuple(c * 0.95)))
    tr = _run(ran)
    assert energy_balance(tr, declared)["relative_error"] < 1e-9  # the old check is blind to the fuel map
    audit = energy_audit(tr, declared, "udds")
    assert audit.failed() == ["engine_fuel"]


def test_implausibly_efficient_engine_fails_the_efficiency_check():
    cfg = paper_bus()
    cfg = cfg.replace(engine=cfg.engine.replace(fuel_coeffs=tuple(np.array(cfg.engine.fuel_coeffs) * 0.6)))
    tr = _run(cfg)
    assert energy_balance(tr, cfg)["relative_error"] < 1e-9
    audit = energy_audit(tr, cfg, "udds")  # consistent with its own map, but beyond a diesel's efficiency
    assert audit.failed() == ["engine_efficiency"]


def test_motor_map_changed_in_the_run_only_fails_the_motor_check():
    declared = paper_bus()
    ran = declared.replace(motor=declared.motor.replace(copper_loss_coeff=declared.motor.copper_loss_coeff * 1.05))
    tr = _run(ran)
    assert energy_balance(tr, declared)["relative_error"] < 1e-9
    assert "motor" in energy_audit(tr, declared, "udds").failed()


def test_soc_held_by_a_clamp_fails_the_battery_check():
    cfg = paper_bus()
    tr = {k: v.copy() for k, v in _run(cfg, split=1.0).items()}
    k = int(np.argmax(tr["battery_chem_power_w"] > 20e3))
    tr["soc"][k:] = tr["soc"][k - 1]  # the SOC stays put while the battery delivers: energy from nowhere
    assert energy_balance(tr, cfg)["relative_error"] < 1e-9
    assert energy_audit(tr, cfg, "udds").failed() == ["battery"]


def test_payload_left_out_of_the_road_load_fails():
    cfg = paper_bus()
    tr = _run(cfg, cond=Conditions(payload_kg=3000.0))
    assert energy_audit(tr, cfg, "udds", Conditions(payload_kg=3000.0)).ok
    assert "road_load" in energy_audit(tr, cfg, "udds", Conditions()).failed()


def test_thermal_capacity_changed_in_the_run_only_fails_the_thermal_check():
    declared = paper_bus()
    ran = declared.replace(thermal=declared.thermal.replace(
        coolant_volume_l=declared.thermal.coolant_volume_l * 0.8))
    tr = _run(ran)
    assert energy_audit(tr, declared, "udds").failed() == ["thermal"]


def test_each_reported_loss_is_checked():
    cfg = paper_bus()
    tr = _run(cfg)
    for column, check in (("motor_loss_w", "motor"), ("battery_power_w", "battery"), ("fuel_g", "engine_fuel"),
                          ("wheel_power_demand_w", "road_load"), ("wheel_power_w", "driveline"),
                          ("q_radiator_w", "thermal")):
        bad = {k: v.copy() for k, v in tr.items()}
        bad[column] = bad[column] * 1.01
        assert check in energy_audit(bad, cfg, "udds").failed(), column
