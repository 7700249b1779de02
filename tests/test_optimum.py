"""The thermal optimum ``dp_thermal``: exact replay, frontier, no strategy below it, grid and exhaustive checks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hev_thermal_env import Conditions, PhysicsCore, cycle_from_arrays, load_cycle, paper_bus
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.envs.reward import RewardParams, stage_cost_g
from hev_thermal_env.evaluation.runner import run_strategy
from hev_thermal_env.evaluation.score import Frontier
from hev_thermal_env.physics.core import (
    BATT_CHEM,
    COOLANT_C,
    CUTOFF,
    HEAT_X,
    MOTOR_TORQUE,
    N_STATE,
    SOC,
    TEMP_C,
    WINDING_C,
)
from hev_thermal_env.planning import stage
from hev_thermal_env.planning.problem import DPProblem, stage_splits
from hev_thermal_env.planning.search import SearchGrid, frontier_points, heat_stays_cheap, search, seed_splits
from hev_thermal_env.planning.stage import (
    KEY_BITS,
    KEY_COLUMNS,
    dominated_by_fuller,
    keep_best_per_bin,
    pareto_per_soc_bin,
)
from hev_thermal_env.prices import Prices


@pytest.fixture(scope="module")
def city200():
    return cycle_from_arrays(load_cycle("beijing").speed_mps[:201], name="beijing_200s")


@pytest.fixture(scope="module")
def hot_runs(city200):
    """Every classic strategy and the optimum on 200 s of Beijing in the hot scenario (motor near its limits)."""
    names = ("dp_thermal", "engine_only", "rule", "ecms", "aecms", "ecms_thermal", "dp")
    return {n: run_strategy(get_strategy(n), city200, "hot").summary for n in names}


def independent_cost_g(summary: dict) -> float:
    """Fuel + missed wheel energy at the miss price, from the metrics (overheat terms are zero below 60 °C)."""
    lhv = paper_bus().engine.fuel_lhv_j_per_g
    return summary["fuel_g"] + summary["missed_wheel_energy_kwh"] * 3.6e6 * Prices().miss_g_per_j(lhv)


def test_planned_cost_is_the_realised_cost(city200):
    """The plan is an exact action sequence: the env realises its planned cost (and the yardstick cost agrees)."""
    res = run_strategy(get_strategy("dp_thermal"), city200, "paper")
    s = res.summary
    d = s["strategy_settings"]
    assert d["planned_cost_g"] == pytest.approx(d["replayed_cost_g"], rel=1e-12)
    assert s["cost_g"] == pytest.approx(d["planned_cost_g"], rel=1e-9)
    assert s["soc_final"] == pytest.approx(d["planned_soc_final"], abs=1e-9)
    assert s["max_motor_temp_c"] < 60.0  # so the overheat terms are zero and the cost is fuel + priced miss
    assert s["cost_g"] == pytest.approx(independent_cost_g(s), rel=1e-6)
    assert abs(s["delta_soc"]) <= 0.005 + 1e-9


def test_frontier_is_monotone_and_spans_the_band(hot_runs):
    d = hot_runs["dp_thermal"]["strategy_settings"]
    f = Frontier.from_settings(d)
    soc, cost = np.array(d["frontier"]["soc_final"]), np.array(d["frontier"]["cost_g"])
    assert np.all(np.diff(soc) > 0) and np.all(np.diff(cost) >= 0)
    # the band's ±0.005, up to what 200 s can charge (a charge yields where the engine is at full load: +0.00498)
    assert soc[0] < 0.65 - 0.005 and soc[-1] > 0.65 + 0.0045
    own = hot_runs["dp_thermal"]
    assert f.cost_at(own["soc_final"]) <= own["cost_g"] * (1 + 1e-9)


def test_no_classic_strategy_beats_the_optimum_at_equal_charge(hot_runs):
    """Hot scenario: every strategy's cost >= the frontier at its own final SOC (0.1 % tolerance), the hybrid with its
    motor unused (``engine_only``, which ends with less charge) included."""
    assert hot_runs["engine_only"]["soc_final"] < hot_runs["dp_thermal"]["soc_final"] - 0.005
    f = Frontier.from_settings(hot_runs["dp_thermal"]["strategy_settings"])
    for name, s in hot_runs.items():
        ref = f.cost_at(s["soc_final"])
        assert ref is not None, (name, s["soc_final"])
        assert s["cost_g"] >= ref * (1 - 1e-3), (name, s["cost_g"], ref)


def problem_for(speed, scenario_conditions: Conditions, physics: int = 2) -> DPProblem:
    core = PhysicsCore(paper_bus(physics=physics))
    speed = np.asarray(speed, dtype=np.float64)
    return DPProblem(core=core, speed_mps=speed, grade=np.zeros_like(speed), k0=0,
                     state0=core.initial_state(scenario_conditions, 1)[0],
                     cond=core.conditions_array(scenario_conditions, 1)[0],
                     reward_params=RewardParams.for_physics(physics), soc_target=scenario_conditions.initial_soc,
                     name="short")


@pytest.mark.parametrize("threads, block_rows", [(1, 4096), (2, 4096), (2, 100)])
def test_a_stage_stepped_in_blocks_on_threads_is_the_env_step_and_cost(monkeypatch, threads, block_rows):
    """:func:`~hev_thermal_env.planning.stage.expand` (one compiled call per thread, blocks dealt in turn) gives, bit
    for bit, the core's step and the reward's stage cost of every state × split, added to the parent's cost-to-come,
    and the parent's battery energy plus the step's: on a hot motor with varied states, in traction and braking."""
    monkeypatch.setattr(stage, "BLOCK_ROWS", block_rows)
    speed = np.array([4.0, 5.5, 7.0, 5.0, 3.0])
    p = problem_for(speed, Conditions(ambient_temp_c=40.0, initial_motor_temp_c=62.0))
    rng = np.random.default_rng(3)
    states = np.repeat(p.state0[None, :], 300, axis=0)
    states[:, SOC] += rng.uniform(-0.05, 0.05, 300)
    for col, lo, hi in ((TEMP_C, -10.0, 15.0), (WINDING_C, 0.0, 60.0), (COOLANT_C, -5.0, 10.0)):
        states[:, col] += rng.uniform(lo, hi, 300)
    states[:, HEAT_X] = rng.uniform(-0.3, 0.6, 300)
    states[::7, CUTOFF] = 1.0
    cost, batt_j = rng.uniform(0.0, 50.0, 300), rng.uniform(-1e5, 1e5, 300)
    u = np.linspace(-1.0, 1.0, 31)
    for i in (1, 3):  # traction, braking
        so, c, e, a = stage.expand(p, i, states, cost, batt_j, u, threads, stage.StageBuffers(p))
        rep = np.repeat(states, u.size, axis=0)
        ref_so, out = p.step(rep, np.tile(u, 300), i)
        ref_c = stage_cost_g(p.reward_params, out, ref_so, p.soc_target, p.lhv, 1.0, battery=False, overheat=True)
        np.testing.assert_array_equal(a, np.tile(u, 300))
        np.testing.assert_array_equal(so, ref_so)
        np.testing.assert_array_equal(c, ref_c + np.repeat(cost, u.size))
        np.testing.assert_array_equal(e, np.repeat(batt_j, u.size) + out[:, BATT_CHEM] * 1.0)
    assert np.any(out[:, MOTOR_TORQUE] < 0.0) and np.any(ref_c != ref_c[0])


def test_the_search_runs_with_one_blas_thread():
    """The stage's heat at its price is numpy's one matrix product in the search; OpenBLAS's idle threads spin after
    it on the cores the stage's threads step on (HWFET with two threads took longer than with one), so the search
    holds BLAS to one thread while it runs and gives it back after."""
    from threadpoolctl import threadpool_info

    def blas_threads() -> list[int]:
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    assert before, "numpy's BLAS is not visible to threadpoolctl"
    seen = []
    p = problem_for(np.array([0.0, 2.0, 4.0, 3.0, 1.0]), Conditions())
    search(p, SearchGrid(n_u=7), (0.6, 0.7), heat_price=np.full((p.n_stages + 1, 3), 0.01),
           progress=lambda *_: seen.append(blas_threads()))
    assert seen and all(t and max(t) == 1 for t in seen)
    assert max(blas_threads()) == max(before)


@pytest.mark.parametrize("heat_free", [False, True], ids=["temperature bins as given", "widest temperature bins"])
def test_search_matches_an_exhaustive_search_on_a_short_cycle(heat_free):
    """Seven seconds, pulling with 7 splits and braking with the shares {0, 1/3, 2/3, 1} of the available
    regeneration, a hot motor: every sequence against the search on the same splits (fine SOC bins: on so short a
    run one default bin of charge is worth 0.3 % of the cost). Also with heat priced at 0 everywhere, where every
    temperature bin is at its widest (:meth:`SearchGrid.stage_widths`)."""
    speed = np.array([0.0, 1.5, 3.0, 4.6, 6.0, 4.4, 2.8, 1.5])
    p = problem_for(speed, Conditions(ambient_temp_c=40.0, initial_motor_temp_c=66.0))
    grid = SearchGrid(soc=1e-5, n_u=7)
    res = search(p, grid, (0.55, 0.75), heat_price=np.zeros((p.n_stages + 1, 3)) if heat_free else None)
    kinds = p.stage_kinds()
    np.testing.assert_array_equal(kinds, [1, 1, 1, 1, -1, -1, -1])
    u_grid = np.linspace(-1.0, 1.0, 7).astype(np.float32).astype(np.float64)
    choices = [stage_splits(k, u_grid) for k in kinds]
    assert [c.size for c in choices] == [7] * 4 + [4] * 3
    seqs = np.array(list(itertools.product(*choices)))
    st = np.repeat(p.state0[None, :], len(seqs), axis=0)
    cost = np.zeros(len(seqs))
    for i in range(p.n_stages):
        st, out = p.step(st, seqs[:, i], i)
        cost += stage_cost_g(p.reward_params, out, st, p.soc_target, p.lhv, 1.0, battery=False, overheat=True)
    soc_f, f = frontier_points(res.final_state[:, SOC], res.final_cost_g)
    for s in np.quantile(st[:, SOC], [0.1, 0.3, 0.5, 0.7, 0.9]):
        exact = cost[st[:, SOC] >= s].min()
        found = f[np.searchsorted(soc_f, s)]  # the search's cheapest path ending at SOC >= s
        assert exact <= found + 1e-9
        assert found <= exact * 1.001, (s, exact, found)


def test_a_seed_path_survives_the_search_to_its_own_final_state():
    """A seed (here a poor one: the motor asked for 37 % of every pull, 80 % of every regeneration) is never dropped:
    its own replay's final state and cost are among the last survivors, to the last digit."""
    speed = np.r_[np.linspace(0.0, 12.0, 25), np.full(20, 12.0), np.linspace(12.0, 0.0, 16)]
    p = problem_for(speed, Conditions(ambient_temp_c=40.0, initial_motor_temp_c=66.0))
    kinds = p.stage_kinds()
    u = np.where(kinds > 0, 0.37, np.where(kinds < 0, 0.8, -0.5)).astype(np.float32)
    seeds = seed_splits(p, u)
    assert np.all(seeds[0][kinds == 0] == 0.0) and np.all(seeds[0][kinds > 0] == np.float32(0.37))
    st, cost = p.state0[None, :].copy(), 0.0
    for i in range(p.n_stages):
        st, out = p.step(st, np.array([u[i]], dtype=np.float64), i)
        cost += float(stage_cost_g(p.reward_params, out, st, p.soc_target, p.lhv, 1.0, battery=False,
                                   overheat=True)[0])
    for seeded in (None, seeds):
        res = search(p, SearchGrid(soc=1e-4, n_u=9), (0.55, 0.75), seeds=seeded)
        hit = np.flatnonzero((res.final_state[:, SOC] == st[0, SOC]) & (res.final_cost_g == cost))
        assert hit.size == (0 if seeded is None else 1)
    np.testing.assert_array_equal(res.path(int(hit[0])).astype(np.float32), seeds[0].astype(np.float32))
    with pytest.raises(ValueError, match="seed path has 3 actions"):
        seed_splits(p, u[:3])


def test_the_optimum_is_no_dearer_than_its_seed_at_its_final_charge(hot_runs):
    """``dp_thermal`` is seeded with ``ecms_thermal``'s run: the frontier at the seed's final SOC is at most its cost,
    and the seed's replayed cost is the cost ``ecms_thermal`` realises in the env."""
    d = hot_runs["dp_thermal"]["strategy_settings"]
    seed = d["seeds"]["ecms_thermal"]
    assert seed["cost_g"] == pytest.approx(hot_runs["ecms_thermal"]["cost_g"], rel=1e-12)
    assert seed["soc_final"] == pytest.approx(hot_runs["ecms_thermal"]["soc_final"], abs=1e-12)
    assert Frontier.from_settings(d).cost_at(seed["soc_final"]) <= seed["cost_g"] * (1 + 1e-12)


@pytest.mark.full
def test_grid_doubling_changes_the_optimum_little(city200):
    """Every bin halved and the split grid doubled: the optimum's cost moves by <= 0.3 % (hot, where heat binds)."""
    short = cycle_from_arrays(city200.speed_mps[:101], name="beijing_100s")
    base = run_strategy(get_strategy("dp_thermal"), short, "hot").summary
    fine = run_strategy(get_strategy("dp_thermal", grid_scale=2.0), short, "hot").summary
    f_fine = Frontier.from_settings(fine["strategy_settings"])
    assert abs(base["cost_g"] - f_fine.cost_at(base["soc_final"])) / base["cost_g"] <= 0.003


@pytest.mark.full
def test_a_much_finer_search_on_a_short_city_cycle_agrees(city200):
    """grid_scale=4 on 100 s: bins narrow enough that a 17-bit SOC key field once merged every SOC into one bin.

    The finer search does not contain the default's paths (its bins keep other representatives), so it may end a
    hair dearer at the same final SOC (here 0.001 %), never by more than 0.01 %; the default is within 0.1 % of it."""
    short = cycle_from_arrays(load_cycle("udds").speed_mps[:101], name="udds_100s")
    base = run_strategy(get_strategy("dp_thermal"), short, "paper").summary
    fine = run_strategy(get_strategy("dp_thermal", grid_scale=4.0), short, "paper").summary
    at = Frontier.from_settings(fine["strategy_settings"]).cost_at(base["soc_final"])
    assert at is not None and at <= base["cost_g"] * (1 + 1e-4)  # finer is at most a hair dearer...
    assert (base["cost_g"] - at) / base["cost_g"] <= 0.001  # ...and the default within 0.1 % of it


def test_temperature_bins_widen_only_where_heat_is_cheap():
    """A stage's housing, winding and coolant bins hold 1 g of heat at the stage's price, between their width and 8
    times it; SOC, heat index and the flags keep theirs; a finer grid narrows both the bins and the grams."""
    g = SearchGrid()
    base = g.widths()
    cols = [KEY_COLUMNS.index(c) for c in (TEMP_C, WINDING_C, COOLANT_C)]
    others = [k for k in range(len(KEY_COLUMNS)) if k not in cols]
    np.testing.assert_array_equal(g.stage_widths(None), base)
    free = g.stage_widths(np.zeros(3))
    np.testing.assert_allclose(free[cols], 8.0 * base[cols])
    np.testing.assert_array_equal(free[others], base[others])
    np.testing.assert_array_equal(g.stage_widths(np.array([50.0, 5.0, 20.0])), base)  # hot: heat binds
    mixed = g.stage_widths(np.array([0.125, 0.01, 1.0]))  # 8 K of housing, 100 K of winding (capped), 1 K of coolant
    np.testing.assert_allclose(mixed[cols], [8.0, 8.0 * base[cols[1]], base[cols[2]]])
    assert mixed[cols[0]] * 0.125 == pytest.approx(g.heat_bin_g)
    fine = g.scaled(2.0).stage_widths(np.array([0.125, 0.01, 1.0]))
    np.testing.assert_allclose(fine[:5], mixed[:5] / 2.0)  # the two protection flags' bins stay 1


def test_a_bin_too_narrow_for_the_key_is_refused():
    problem = problem_for(load_cycle("udds").speed_mps[:31], Conditions())
    with pytest.raises(ValueError, match="soc bin 1e-07 is too narrow"):
        search(problem, SearchGrid(soc=1e-7), (0.6, 0.7))


def test_dominance_keeps_cooler_states_and_same_bin_pairs():
    # rows: SOC bin, then (winding, housing, coolant, heat, cutoff) bin indices; order = by SOC bin, then cost
    soc_bin = np.array([0, 0, 0, 0, 1], dtype=np.int64)
    q = np.array([[5, 5, 5, 0, 0],   # cheapest
                  [6, 5, 5, 0, 0],   # dearer and hotter: dominated
                  [4, 6, 5, 0, 0],   # dearer, cooler winding, hotter housing: kept
                  [5, 5, 5, 0, 0],   # dearer, same bin as the cheapest (the bin's coolest): kept
                  [9, 9, 9, 1, 1]], dtype=np.int64)  # other SOC bin: kept
    keep = np.empty(5, dtype=np.int64)
    k = pareto_per_soc_bin(soc_bin, q, np.arange(5, dtype=np.int64), keep)
    assert sorted(keep[:k].tolist()) == [0, 2, 3, 4]


def test_each_bin_keeps_its_heat_priced_state_and_nothing_more_where_heat_is_free():
    """One bin of four candidates: the cheapest (at the battery price), the cheapest at the second price, the coolest
    and the cheapest with heat priced survive; with heat free the heat-priced one is the cheapest and no fourth row
    comes in."""
    states = np.zeros((4, N_STATE))
    states[:, SOC] = 0.65
    states[:, TEMP_C] = [59.9, 58.1, 59.8, 59.5]  # one 2 K housing bin
    states[:, WINDING_C] = 80.0
    states[:, COOLANT_C] = 50.0
    cost = np.array([100.0, 104.0, 99.0, 100.4])
    batt_j = np.array([0.0, 0.0, 1.1, 0.0])  # row 2 used more charge: the cheapest only at the lower price
    widths = np.array([1.5e-4, 2.0, 8.0, 4.0, 0.1, 1.0, 1.0])
    key_cols, bits = np.array(KEY_COLUMNS, dtype=np.int64), np.array(KEY_BITS, dtype=np.int64)

    def kept(heat_g: np.ndarray, price3: float = 0.0) -> list[int]:
        out = np.empty(8, dtype=np.int64)
        k = keep_best_per_bin(states, np.ones(4, dtype=np.bool_), cost, batt_j, 1.0, 0.8, price3, heat_g, key_cols,
                              widths, bits, 0, 1, 16, out, keep_cool)
        return sorted(out[:k].tolist())

    keep_cool = True
    # no heat price: row 0 cheapest (100 against 100.1, 100.4, 104), row 2 at the price 0.8 (99.88), row 1 coolest
    assert kept(np.zeros(4)) == [0, 1, 2]
    # 2 g/K above 58 °C: row 3 (100.4 + 3.0) beats row 0 (103.8), row 2 (103.7) and row 1 (104.2)
    assert kept(2.0 * (states[:, TEMP_C] - 58.0)) == [0, 1, 2, 3]
    keep_cool = False  # where heat cannot bind: the coolest (row 1) is not kept for itself
    assert kept(np.zeros(4)) == [0, 2]
    # a third battery price in its slot: at 1.2 row 0 is still the cheapest (100 against 100.32, 100.4, 104)
    assert kept(np.zeros(4), price3=1.2) == [0, 2]
    batt_j[3] = -0.36  # row 3 charged more: 100.04 at the price 1 (row 0 stays), 99.968 at 1.2 (below row 0)
    assert kept(np.zeros(4), price3=1.2) == [0, 2, 3]
    assert kept(np.zeros(4)) == [0, 2]


def test_a_fuller_state_of_the_same_thermal_bins_that_costs_no_more_replaces_a_state():
    # rows: SOC bin; thermal bins (housing, winding, coolant, heat index, cutoff, trip); value (cost + priced heat)
    soc_bin = np.array([3, 3, 2, 2, 2, 1, 1], dtype=np.int64)
    q = np.array([[5, 5, 5, 0, 0, 0],    # 0: fullest
                  [6, 5, 5, 0, 0, 0],    # 1: fullest, another housing bin
                  [5, 5, 5, 0, 0, 0],    # 2: emptier than 0, same bins, dearer: replaced
                  [5, 5, 5, 0, 0, 0],    # 3: emptier than 0, same bins, cheaper: kept
                  [6, 5, 5, 0, 0, 0],    # 4: emptier than 1, cheaper: kept
                  [5, 5, 5, 1, 0, 0],    # 5: another heat-index bin: kept however dear
                  [6, 5, 5, 0, 0, 0]], dtype=np.int64)  # 6: dearer than 1 and 4 but as dear as 4: replaced (a tie)
    value = np.array([10.0, 20.0, 10.5, 9.0, 12.0, 99.0, 12.0])
    order = np.argsort(-soc_bin, kind="stable")
    out = np.zeros(7, dtype=np.bool_)
    assert dominated_by_fuller(soc_bin, q, value, order, out) == 2
    assert np.flatnonzero(out).tolist() == [2, 6]
    same_bin = np.zeros(2, dtype=np.bool_)  # one SOC bin: its representatives never replace each other
    assert dominated_by_fuller(np.array([4, 4]), q[:2] * 0, np.array([1.0, 2.0]), np.arange(2), same_bin) == 0


def test_heat_stays_cheap_only_where_no_later_stage_prices_a_bin_above_a_gram():
    g = SearchGrid()  # bins of 2 K (housing), 8 K (winding), 4 K (coolant): a gram at 0.5, 0.125, 0.25 g/K
    n = 6
    price = np.zeros((n + 1, 3))
    price[:, 0] = 0.4  # 0.8 g in a housing bin: cheap
    assert heat_stays_cheap(g, price, n).tolist() == [True] * n + [False]  # never at the last stage
    price[3, 1] = 0.2  # 1.6 g in a winding bin after stage 3: not cheap up to there
    assert heat_stays_cheap(g, price, n).tolist() == [False] * 4 + [True] * 2 + [False]
    price[5, 2] = np.nan  # a price that is not a number: not cheap
    assert not heat_stays_cheap(g, price, n).any()
    assert not heat_stays_cheap(g, None, n).any()
    for prices, cheap in (([0.45, 0.12, 0.24], True), ([0.55, 0.12, 0.24], False)):  # wider bins, more grams: same
        for grid in (g, g.scaled(0.5)):
            assert heat_stays_cheap(grid, np.tile(prices, (n + 1, 1)), n)[0] == cheap


@pytest.mark.parametrize("options, match", [
    ({"grid_scale": 0}, "grid_scale"), ({"n_u": 1}, "n_u"), ({"soc_bin": -1e-4}, "soc"),
    ({"on_infeasible": "maybe"}, "on_infeasible"), ({"frontier_halfwidth": 0.001}, "frontier_halfwidth"),
    ({"n_soc": 101}, "unknown option"), ({"seed_with": ["dp"]}, "not a teacher strategy"),
])
def test_bad_options_name_the_problem(options, match):
    with pytest.raises(ValueError, match=match):
        get_strategy("dp_thermal", **options)


def test_a_solved_plan_is_reused_from_disk_and_drives_the_same_run(city200):
    short = cycle_from_arrays(city200.speed_mps[:61], name="beijing_60s")
    first = run_strategy(get_strategy("dp_thermal"), short, "hot").summary
    again = run_strategy(get_strategy("dp_thermal"), short, "hot").summary
    fresh = run_strategy(get_strategy("dp_thermal", plan_cache=False), short, "hot").summary
    assert again["strategy_settings"].get("from_cache") is True
    assert "from_cache" not in fresh["strategy_settings"]
    assert again["cost_g"] == first["cost_g"] == fresh["cost_g"]
    assert again["soc_final"] == first["soc_final"]


def test_heat_is_priced_where_it_costs_and_not_where_it_does_not(city200):
    """The price of a kelvin (``planning.search.heat_prices``) along the hybrid driven at u = 1, with
    physics v1's prices (a soft limit at 60 °C): nothing on a cool motor (paper: below the derate's 35 °C and far
    from the soft limit), a little on a hot one (the derate), grams per kelvin of the housing above the overheat soft
    limit; the housing's price from a direct difference of two replays from stage 100 (2 K apart) agrees."""
    import dataclasses

    from hev_thermal_env.planning.search import DELTA_K, heat_prices
    from hev_thermal_env.scenarios import get_scenario

    hot = get_scenario("hot").conditions
    cases = {"paper": get_scenario("paper").conditions, "hot": hot,
             "above_soft_limit": dataclasses.replace(hot, initial_motor_temp_c=62.0)}
    problems = {k: problem_for(city200.speed_mps, c, physics=1) for k, c in cases.items()}
    prices = {k: heat_prices(p, np.ones(p.n_stages)) for k, p in problems.items()}
    assert prices["paper"].max() == 0.0
    assert 0.01 < prices["hot"][100, 0] < 1.0
    assert prices["above_soft_limit"][100, 0] > 1.0
    assert all(np.all(m >= 0.0) and np.all(m[-1] == 0.0) for m in prices.values())
    p = problems["above_soft_limit"]
    st = p.state0[None, :].copy()
    for i in range(100):
        st, _ = p.step(st, 1.0, i)
    lam = p.reward_params.prices.battery_g_per_j(p.lhv)
    totals = []
    for sign in (1.0, -1.0):
        x = st.copy()
        x[0, TEMP_C] += sign * DELTA_K
        total = 0.0
        for i in range(100, p.n_stages):
            x, out = p.step(x, 1.0, i)
            total += float(stage_cost_g(p.reward_params, out, x, p.soc_target, p.lhv, 1.0, battery=False,
                                        overheat=True)[0]) + lam * float(out[0, BATT_CHEM])
        totals.append(total)
    direct = (totals[0] - totals[1]) / (2 * DELTA_K)
    assert prices["above_soft_limit"][100, 0] == pytest.approx(direct, rel=1e-9)
