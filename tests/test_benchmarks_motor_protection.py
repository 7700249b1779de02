"""The motor-protection benchmark's own arithmetic (benchmarks/motor_protection.py) on hand-made traces."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("motor_protection", ROOT / "benchmarks/motor_protection.py")
mp = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(mp)  # a script beside the benchmark, not a package module


def _trace(**columns):
    base = {"motor_heat_w": [100.0, 300.0, 50.0, 200.0], "motor_torque_nm": [50.0, -80.0, -10.0, -40.0],
            "shaft_torque_demand_nm": [120.0, -200.0, 30.0, -5.0], "motor_elec_power_w": [9e3, -4e3, -1e3, -2e3]}
    return {k: np.asarray(v) for k, v in (base | columns).items()}


def test_regen_heat_counts_only_braking_steps_where_the_motor_generates():
    # steps 1 and 3 regenerate (motor < 0, shaft < 0); step 2 charges from the engine while driving (shaft > 0)
    got = mp.regen_heat(_trace(), dt_s=2.0)
    assert got["motor_heat_j"] == pytest.approx(2.0 * 650.0)
    assert got["regen_heat_j"] == pytest.approx(2.0 * 500.0)
    assert got["regen_heat_share"] == pytest.approx(500.0 / 650.0)
    assert got["regen_s"] == 4.0
    assert got["regen_elec_kwh"] == pytest.approx(2.0 * 6e3 / 3.6e6)


def test_regen_heat_share_is_none_without_motor_heat():
    got = mp.regen_heat(_trace(motor_heat_w=np.zeros(4)), dt_s=1.0)
    assert got["regen_heat_share"] is None and got["motor_heat_j"] == 0.0


def test_winding_trip_seconds_only_where_the_state_has_the_protection():
    summary = {"duration_s": 4.0}
    trace = _trace(fuel_g=np.ones(4))
    assert mp.cell_row(summary, trace, {})["winding_trip_s"] is None
    trace["winding_trip"] = np.asarray([0.0, 1.0, 1.0, 0.0])
    assert mp.cell_row(summary, trace, {})["winding_trip_s"] == 2.0


def test_optimum_against_engine_only_compares_equal_charge_not_raw_cost():
    """engine_only ends with less charge (it regenerates nothing): a raw cost below the optimum's is no contradiction;
    the verdict reads its frontier ratio (cost over the optimum's at its own final SOC)."""
    def row(strategy, cost_g, ratio):
        return {"scenario": mp.HOT, "cycle": "udds", "strategy": strategy, "cost_g": cost_g, "frontier_ratio": ratio}

    cheaper_raw = [row(mp.OPTIMUM, 4969.0, 1.0), row(mp.ENGINE_ONLY, 4959.0, 1.024)]
    got = mp.hot_table(cheaper_raw, ["udds"], [mp.OPTIMUM, mp.ENGINE_ONLY])["udds"]
    assert got["optimum_le_engine_only_at_equal_charge"] is True
    assert got["optimum_raw_cost_le_engine_only"] is False
    below = [row(mp.OPTIMUM, 4969.0, 1.0), row(mp.ENGINE_ONLY, 4900.0, 0.995)]
    assert mp.hot_table(below, ["udds"], [mp.OPTIMUM, mp.ENGINE_ONLY])["udds"][
        "optimum_le_engine_only_at_equal_charge"] is False
