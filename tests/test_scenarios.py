"""Scenarios where heat matters: summer, hilly, full bus; the hilly road from the cycle generator."""

from __future__ import annotations

import numpy as np
import pytest

from hev_thermal_env import load_cycle, paper_bus, simulate
from hev_thermal_env.cycles import generate_bus_cycle, generate_grade_profile, with_grade_profile
from hev_thermal_env.cycles.generator import HILLY_KWARGS, HILLY_SEED
from hev_thermal_env.scenarios import get_scenario, list_scenarios


def test_new_scenarios_are_listed():
    assert {"paper", "hot", "summer", "hilly", "full_bus", "random"} <= set(list_scenarios())
    assert 35.0 <= get_scenario("summer").conditions.ambient_temp_c <= 40.0
    assert 0.0 < get_scenario("full_bus").conditions.payload_kg <= 5000.0
    assert get_scenario("hilly").grade_profile["seed"] == HILLY_SEED


def test_grade_profile_is_seeded_bounded_and_closed():
    pos, g = generate_grade_profile(5, 8000.0, **HILLY_KWARGS)
    pos2, g2 = generate_grade_profile(5, 8000.0, **HILLY_KWARGS)
    np.testing.assert_array_equal(g, g2)
    assert np.all(np.abs(g) <= HILLY_KWARGS["max_grade"] + 1e-12) and pos[-1] >= 8000.0
    climb = np.trapezoid(np.interp(np.linspace(0, pos[-1], 20001), pos, g), dx=pos[-1] / 20000)
    assert abs(climb) < 1.0  # metres over the whole route: no net climb
    assert not np.array_equal(g, generate_grade_profile(6, 8000.0, **HILLY_KWARGS)[1])


def hilly_route():
    """``beijing`` over the ``hilly`` scenario's road (named ``hilly``)."""
    return with_grade_profile(load_cycle("beijing"), HILLY_SEED, name="hilly", **HILLY_KWARGS)


def test_hilly_route_keeps_the_speeds_and_flat_cycles_unchanged():
    bj = load_cycle("beijing")
    h = hilly_route()
    assert h.name == "hilly" and h.synthetic
    np.testing.assert_array_equal(h.speed_mps, bj.speed_mps)
    assert np.all(bj.grade == 0.0) and np.abs(h.grade).max() > 0.03
    # the generator's flat cycles are untouched by the grade feature (beijing = seed 171)
    assert np.array_equal(generate_bus_cycle(171, 1300.0).speed_mps, bj.speed_mps)


def test_prepare_cycle():
    hilly = get_scenario("hilly")
    c = hilly.prepare_cycle("udds")
    assert np.abs(c.grade).max() > 0.0
    np.testing.assert_array_equal(c.speed_mps, load_cycle("udds").speed_mps)
    graded = with_grade_profile(load_cycle("udds"), 3)
    assert hilly.prepare_cycle(graded) is graded  # a cycle with its own grade keeps it
    assert get_scenario("paper").prepare_cycle("udds").name == "udds"


@pytest.mark.parametrize("scenario", ["summer", "hilly", "full_bus"])
def test_heat_matters_in_the_new_scenarios(scenario):
    sc = get_scenario(scenario)
    cyc = sc.prepare_cycle("udds")
    hot = simulate(cyc, paper_bus(), 0.6, sc.conditions).summary
    ref = simulate("udds", paper_bus(), 0.6, get_scenario("paper").conditions).summary
    assert hot["derated_s"] > ref["derated_s"] or hot["max_motor_temp_c"] > ref["max_motor_temp_c"] + 5.0


def test_thermal_blind_ecms_derates_more_than_thermal_ecms():
    from hev_thermal_env.agents import get_strategy
    from hev_thermal_env.agents.ecms import THERMAL_PRICES
    from hev_thermal_env.evaluation.runner import run_strategy
    sc = get_scenario("summer")
    blind = run_strategy(get_strategy("ecms"), "udds", sc).summary
    aware = run_strategy(get_strategy("ecms_thermal"), "udds", sc).summary  # physics v2's price: derating itself
    assert 0.0 < aware["derated_s"] < blind["derated_s"]
    assert aware["cost_g"] <= 1.005 * blind["cost_g"]
    v1_prices = run_strategy(get_strategy("ecms_thermal", **THERMAL_PRICES[1]), "udds", sc).summary
    assert blind["derated_s"] > v1_prices["derated_s"] + 60.0
