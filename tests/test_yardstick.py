"""The benchmark's yardstick: the thermal optimum's frontier, the yardstick cost, the J1711 flag, the seed
statistics (IQM and bootstrap intervals) and seed families, from the library to the command line."""

from __future__ import annotations

import csv
import json
import shutil

import numpy as np
import pytest

import hev_thermal_env.evaluation.benchmark as bench
from hev_thermal_env import load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.agents.ppo import DEFAULT_POLICY_DIR
from hev_thermal_env.cli.evaluate import main as evaluate_main
from hev_thermal_env.cycles import cycle_from_arrays
from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.evaluation import run_strategy
from hev_thermal_env.evaluation.benchmark import OVERALL, Family, family_rows, parse_family, tag_members
from hev_thermal_env.evaluation.score import Frontier, add_yardstick_columns, frontier_ratio, with_reference
from hev_thermal_env.metrics import J1711_TOLERANCE, charge_sustaining, summarize, yardstick_cost_g
from hev_thermal_env.physics import Conditions, core, paper_bus
from hev_thermal_env.stats import iqm, iqm_ci, stratified_iqm_ci

FRONTIER = {"soc_final": [0.60, 0.64, 0.66, 0.70], "cost_g": [1000.0, 1100.0, 1140.0, 1200.0], "grid": "test grid"}


# --- the frontier ----------------------------------------------------------------------------------------

def test_frontier_interpolates_linearly_between_its_points():
    f = Frontier.from_settings({"frontier": FRONTIER})
    assert f.cost_at(0.60) == 1000.0 and f.cost_at(0.70) == 1200.0 and f.cost_at(0.66) == 1140.0
    assert f.cost_at(0.62) == pytest.approx(1050.0)  # halfway between 0.60 and 0.64
    assert f.cost_at(0.68) == pytest.approx(1170.0)
    ratio, note = frontier_ratio(1155.0, 0.65, f)  # F(0.65) = 1120
    assert ratio == pytest.approx(1155.0 / 1120.0) and note is None


def test_final_soc_outside_the_frontier_has_no_ratio_and_a_note():
    f = Frontier.from_settings({"frontier": FRONTIER})
    for soc in (0.59, 0.7001):
        ratio, note = frontier_ratio(1000.0, soc, f)
        assert ratio is None and "outside the frontier's range [0.6000, 0.7000]" in note and f"{soc:.4f}" in note
    assert frontier_ratio(1000.0, 0.65, None) == (None, "dp_thermal published no frontier")


@pytest.mark.parametrize("bad, needle", [
    ({"soc_final": [0.6, 0.7], "cost_g": [1.0]}, "same number"),
    ({"soc_final": [0.7, 0.6], "cost_g": [1.0, 2.0]}, "not sorted"),
    ({"soc_final": [0.6, 0.7], "cost_g": [1.0, float("nan")]}, "not finite"),
    ({"cost_g": [1.0]}, "malformed"),
])
def test_a_malformed_frontier_is_named(bad, needle):
    with pytest.raises(ValueError, match=needle):
        Frontier.from_settings({"frontier": bad})


def run_row(strategy, cost_g, soc_final, fuel, cycle="c", frontier=None) -> dict:
    settings = {"frontier": frontier} if frontier is not None else {"grid": {"soc": 101}}
    return {"cycle": cycle, "scenario": "paper", "strategy": strategy, "cost_g": cost_g, "soc_final": soc_final,
            "fuel_corrected_l_per_100km": fuel, "strategy_settings": settings if strategy == "dp_thermal" else {}}


def test_yardstick_columns_from_the_reference_of_the_same_cycle_and_scenario():
    rows = [run_row("rule", 1200.0, 0.62, 33.0), run_row("dp", 1125.0, 0.66, 30.3),
            run_row("dp_thermal", 1140.0, 0.66, 30.0, frontier=FRONTIER), run_row("ecms", 1300.0, 0.55, 31.0),
            run_row("rule", 1.0, 0.65, 40.0, cycle="other"), run_row("dp_thermal", 1.0, 0.65, 20.0, cycle="other")]
    add_yardstick_columns(rows)
    rule, dp, ref, ecms, other_rule, other_ref = rows
    assert rule["frontier_ratio"] == pytest.approx(1200.0 / 1050.0) and rule["frontier_note"] is None
    assert dp["frontier_ratio"] == pytest.approx(1125.0 / 1140.0) and ref["frontier_ratio"] == pytest.approx(1.0)
    assert ecms["frontier_ratio"] is None and "outside" in ecms["frontier_note"]
    assert rule["fixed_price_ratio"] == pytest.approx(1.1) and ref["fixed_price_ratio"] == 1.0
    assert rule["fuel_vs_thermal_blind_dp_pct"] == pytest.approx(100 * 33.0 / 30.3)
    assert rule["reference"] == "dp_thermal: test grid"
    # the other cycle's reference published no frontier: no frontier ratio, but the fixed-price ratio stands
    assert other_rule["frontier_ratio"] is None and "no frontier" in other_rule["frontier_note"]
    assert other_rule["fixed_price_ratio"] == pytest.approx(2.0) and other_rule["fuel_vs_thermal_blind_dp_pct"] is None
    assert other_ref["reference"] == "dp_thermal (no frontier published; grid soc 101)"
    assert with_reference(["rule", "dp"]) == (["rule", "dp", "dp_thermal"], True)
    assert with_reference(["dp_thermal", "rule"]) == (["dp_thermal", "rule"], False)


# --- the SAE J1711 flag and the yardstick cost -------------------------------------------------------------

def test_j1711_flag_from_independent_numbers():
    lhv = 42_600.0  # J/g
    fuel_g = 1000.0  # 42.6 MJ of fuel energy: the limit is 426 kJ either way
    assert J1711_TOLERANCE == 0.01
    assert charge_sustaining(400e3, fuel_g, lhv) == (pytest.approx(400e3 / 42.6e6), True)
    assert charge_sustaining(-400e3, fuel_g, lhv) == (pytest.approx(-400e3 / 42.6e6), True)
    assert charge_sustaining(430e3, fuel_g, lhv)[1] is False
    assert charge_sustaining(-430e3, fuel_g, lhv)[1] is False
    assert charge_sustaining(5.0, 0.0, lhv) == (None, False) and charge_sustaining(0.0, 0.0, lhv) == (None, True)
    n = 100  # the metric: 1,000 g of fuel and a net 0.5 MJ drawn from the battery over 100 s
    trace = {"fuel_g": np.full(n, 10.0), "battery_chem_power_w": np.full(n, 5000.0),
             "missed_wheel_energy_j": np.zeros(n), "soc": np.full(n, 0.6), "motor_temp_c": np.full(n, 30.0),
             "heat_index": np.zeros(n), "motor_cutoff": np.zeros(n), "trace_miss_mps": np.zeros(n),
             "engine_on": np.ones(n)}
    config = paper_bus()
    m = summarize(trace, config, 0.65, 1000.0)
    lhv = config.engine.fuel_lhv_j_per_g
    assert m["net_energy_ratio"] == pytest.approx(0.5e6 / (1000.0 * lhv)) and m["charge_sustaining"] is False


def arrays(trace: dict) -> tuple[np.ndarray, np.ndarray]:
    """The physics outputs and states after each step, as [n, N_OUT] and [n, N_STATE] arrays."""
    return (np.column_stack([trace[k] for k in core.OUT_NAMES]), np.column_stack([trace[k] for k in core.STATE_NAMES]))


@pytest.mark.parametrize("physics", [2, 1])
def test_cost_is_fuel_plus_priced_miss_plus_overheat_from_the_trace(physics):
    """v2 prices the winding insulation's life; v1 the housing above 60 °C (0.05 g/K²) and each second cut off
    (20 g)."""
    cyc = cycle_from_arrays(load_cycle("hwfet").speed_mps[:121], name="hwfet_tiny")
    hot = Conditions(initial_motor_temp_c=68.0, coolant="off")  # above the soft limit, then cut off
    res = run_strategy(get_strategy("rule"), cyc, conditions=hot, physics=physics)
    tr = res.trace
    lhv = paper_bus().engine.fuel_lhv_j_per_g
    miss_price = 1.0 / (lhv * 0.36 * 0.90 * 0.90 * 0.93)  # g per J, README "Metrics"
    fuel = tr["fuel_g"].sum()
    miss = tr["missed_wheel_energy_j"].sum() * miss_price
    if physics == 1:
        over_k = np.maximum(tr["motor_temp_c"] - 60.0, 0.0)
        overheat = 0.05 * np.sum(over_k ** 2) + 20.0 * np.sum(tr["motor_cutoff"] > 0)
        assert overheat > 100.0
    else:  # 4.175 t of diesel over 20,000 h at 180 °C, halving every 10 K below it
        overheat = np.sum(4175000.0 / (20000.0 * 3600.0) * 2.0 ** ((tr["winding_temp_c"] - 180.0) / 10.0))
        assert overheat > 0.0
    assert miss > 0.0  # the terms are exercised
    assert res.summary["cost_g"] == pytest.approx(fuel + miss + overheat, rel=1e-9)
    out, state = arrays(tr)
    derating = RewardParams.for_physics(physics).replace(derate_weight=3.0)  # the derate term too, another weight
    extra = 3.0 * np.sum(np.clip(tr["heat_x"], 0.0, 1.0))
    assert extra > 0.0
    assert yardstick_cost_g(out, state, derating, lhv, 1.0) == pytest.approx(fuel + miss + overheat + extra, rel=1e-9)


# --- IQM and bootstrap intervals ---------------------------------------------------------------------------

def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm(range(1, 9)) == pytest.approx(np.mean([3, 4, 5, 6]))
    assert iqm([0, 10, 11, 12, 13, 100]) == pytest.approx(np.mean([10, 11, 12, 13]))


def test_bootstrap_interval_contains_the_iqm_and_narrows_with_more_seeds():
    rng = np.random.default_rng(7)
    widths = []
    for n in (5, 20, 80):
        x = rng.normal(1.05, 0.02, n)
        low, high = iqm_ci(x)
        assert low <= iqm(x) <= high
        widths.append(high - low)
    assert widths[0] > widths[1] > widths[2]
    assert iqm_ci([1.0]) == (None, None) and iqm_ci([2.0, 2.0, 2.0]) == (2.0, 2.0)


def test_stratified_interval_resamples_within_each_task():
    x = [1.01, 1.02, 1.04, 1.03, 1.08]
    assert stratified_iqm_ci([x]) == (pytest.approx(iqm(x)), *(pytest.approx(v) for v in iqm_ci(x)))
    centre, low, high = stratified_iqm_ci([[1.0, 1.02, 1.01], [1.10, 1.12, 1.11], [float("nan"), 1.05]])
    assert centre == pytest.approx(iqm([1.0, 1.02, 1.01, 1.10, 1.12, 1.11, 1.05])) and low <= centre <= high
    # each resample keeps three scores of each task, so the pooled IQM stays between the tasks' levels
    assert 1.0 < low and high < 1.12
    assert stratified_iqm_ci([[], [float("nan")]]) == (None, None, None)
    assert stratified_iqm_ci([[1.2]]) == (1.2, None, None)


# --- seed families -----------------------------------------------------------------------------------------

@pytest.fixture
def seed_runs(tmp_path):
    """Two run directories (copies of the shipped policy) in one folder, and a stray file beside them."""
    folder = tmp_path / "seeds"
    for name in ("s0", "s1"):
        shutil.copytree(DEFAULT_POLICY_DIR, folder / name)
    (folder / "notes.txt").write_text("not a run\n")
    return folder


def test_family_option_forms(seed_runs):
    by_list = parse_family(f"fam={seed_runs / 's0'},{seed_runs / 's1'}")
    by_folder = parse_family(f"fam={seed_runs}")
    assert by_list == by_folder and by_list.members == (f"ppo:{seed_runs / 's0'}", f"ppo:{seed_runs / 's1'}")
    with pytest.raises(ValueError, match="at least 2 runs, got 1"):
        parse_family(f"fam={seed_runs / 's0'}")
    with pytest.raises(FileNotFoundError, match="nowhere not found"):
        parse_family(f"fam={seed_runs / 's0'},nowhere")
    with pytest.raises(ValueError, match="taken"):
        parse_family(f"rule={seed_runs}", taken=["rule"])
    with pytest.raises(ValueError, match="NAME=PATH"):
        parse_family(str(seed_runs))


def test_family_rows_per_task_and_overall():
    fam = Family("fam", ("a", "b", "c", "d"))
    rows = []
    for cycle, level in (("c1", 1.0), ("c2", 1.2)):
        for k, label in enumerate(fam.members):
            rows.append({"cycle": cycle, "scenario": "paper", "strategy": label, "frontier_ratio": level + 0.01 * k,
                         "fixed_price_ratio": level, "fuel_corrected_l_per_100km": 30.0, "cost_g": 1.0,
                         "charge_sustaining": k < 3, "reference": "dp_thermal: g"})
    rows[0]["frontier_ratio"] = None  # one seed off the frontier on c1
    tag_members(rows, [fam])
    assert {r["family"] for r in rows} == {"fam"}
    c1, c2, overall = family_rows(rows, [fam])
    assert (c1["cycle"], c2["cycle"], overall["cycle"], overall["scenario"]) == ("c1", "c2", OVERALL, OVERALL)
    assert c1["frontier_ratio"] == pytest.approx(iqm([1.01, 1.02, 1.03])) and "1 of 4 runs" in c1["frontier_note"]
    assert c2["frontier_ratio"] == pytest.approx(iqm([1.2, 1.21, 1.22, 1.23]))
    assert c2["frontier_ratio_ci_low"] <= c2["frontier_ratio"] <= c2["frontier_ratio_ci_high"]
    assert overall["frontier_ratio"] == pytest.approx(iqm([1.01, 1.02, 1.03, 1.2, 1.21, 1.22, 1.23]))
    assert overall["runs"] == 8 and overall["charge_sustaining_runs"] == 6 and overall["charge_sustaining"] is False
    assert c2["fixed_price_ratio"] == c2["fixed_price_ratio_ci_low"] == 1.2  # every seed alike: a point


# --- end to end: the benchmark with a reference frontier, and the command line -------------------------------

@pytest.fixture
def tiny_cycle_csv(tmp_path):
    v = load_cycle("beijing").speed_mps[100:221]
    path = tmp_path / "tiny.csv"
    path.write_text("time_s,speed_mps\n" + "".join(f"{t},{x}\n" for t, x in enumerate(v)))
    return str(path)


@pytest.fixture
def reference_frontier(monkeypatch):
    """dp_thermal publishes a frontier through its own run: its cost, rising 20,000 g per unit of final SOC."""
    run_one = bench._run_one

    def with_frontier(task):
        summary, trace = run_one(task)
        if summary["strategy"] == "dp_thermal":
            soc = summary["soc_final"] + np.linspace(-0.02, 0.02, 9)
            summary["strategy_settings"]["frontier"] = {
                "soc_final": soc.tolist(), "cost_g": (summary["cost_g"] + 2e4 * (soc - summary["soc_final"])).tolist(),
                "grid": "test frontier, 9 SOC points"}
        return summary, trace

    monkeypatch.setattr(bench, "_run_one", with_frontier)


def test_benchmark_with_a_family_writes_the_new_columns(reference_frontier, tiny_cycle_csv, seed_runs, tmp_path,
                                                       capsys):
    out = tmp_path / "bench"
    code = evaluate_main(["benchmark", "--cycles", tiny_cycle_csv, "--strategies", "rule", "--family",
                          f"fam={seed_runs}", "--out", str(out), "--jobs", "1"])
    printed = capsys.readouterr().out
    assert code == 0 and "dp_thermal was added to the strategies" in printed and "4 runs" in printed
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert [(r["strategy"].split("/")[-1], r["family"], r["cycle"]) for r in rows] == [
        ("rule", "", "tiny"), ("dp_thermal", "", "tiny"), ("s0", "fam", "tiny"), ("s1", "fam", "tiny"),
        ("fam", "fam", "tiny"), ("fam", "fam", OVERALL)]
    rule, ref, s0, s1, fam, overall = rows
    assert float(ref["frontier_ratio"]) == pytest.approx(1.0) and float(ref["fixed_price_ratio"]) == 1.0
    assert ref["reference"] == rule["reference"] == "dp_thermal: test frontier, 9 SOC points"
    data = json.loads((out / "results.json").read_text())["rows"]
    expect = data[0]["cost_g"] / (data[1]["cost_g"] + 2e4 * (data[0]["soc_final"] - data[1]["soc_final"]))
    assert data[0]["frontier_ratio"] == pytest.approx(expect)
    assert float(fam["frontier_ratio"]) == pytest.approx(float(s0["frontier_ratio"]))  # identical seeds
    assert fam["seeds"] == "2" and float(fam["frontier_ratio_ci_low"]) == pytest.approx(float(fam["frontier_ratio"]))
    assert rule["charge_sustaining"] in ("True", "False") and rule["net_energy_ratio"]
    md = (out / "results.md").read_text()
    assert "**fam** (IQM of 2 seeds)" in md and "Seed families over every cycle × scenario" in md
    assert "seeds/s0" not in md  # the members are in results.csv, not one by one in the table
    assert (out / "fuel_vs_optimum.png").stat().st_size > 20_000


def test_below_the_first_point_the_frontier_is_the_cheapest_path_with_at_least_that_charge():
    from hev_thermal_env.evaluation.score import Frontier

    f = Frontier.from_settings({"frontier": {"soc_final": [0.64, 0.65, 0.66], "cost_g": [100.0, 110.0, 125.0],
                                             "soc_min": 0.60, "grid": "g"}})
    assert f.cost_at(0.62) == 100.0 and f.cost_at(0.645) == 105.0
    assert f.cost_at(0.59) is None and f.cost_at(0.67) is None
    assert Frontier.from_settings({"frontier": {"soc_final": [0.64], "cost_g": [1.0]}}).cost_at(0.63) is None
