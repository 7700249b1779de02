"""Strategies behind one protocol: registry, each strategy's logic, ordering on a short cycle, ``evaluate.py run``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hev_thermal_env import Conditions, cycle_from_arrays, load_cycle, paper_bus
from hev_thermal_env.agents import get_strategy, list_strategies
from hev_thermal_env.agents.ecms import ECMS, REWARD_EQUIVALENCE_FACTOR, THERMAL_PRICES, AdaptiveECMS, ecms_cost_g
from hev_thermal_env.agents.rule import RuleBased
from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.envs.reward import RewardParams, stage_cost_g
from hev_thermal_env.evaluation.plots import plot_run
from hev_thermal_env.evaluation.runner import SUMMARY_KEYS, run_strategy
from hev_thermal_env.physics.core import BATT_CHEM, FUEL_G, HEAT_X, SHAFT_DEMAND, SOC, TEMP_C
from hev_thermal_env.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
ALL = ("conventional", "engine_only", "rule", "ecms", "aecms", "ecms_thermal", "dp", "dp_thermal")


@pytest.fixture(scope="module")
def city200():
    """The first 200 s of the synthetic Beijing bus cycle (stops, launches, regeneration)."""
    return cycle_from_arrays(load_cycle("beijing").speed_mps[:201], name="beijing_200s")


@pytest.fixture(scope="module")
def runs(city200):
    """Every strategy on the 200 s city cut, paper scenario (shared by several tests)."""
    return {name: run_strategy(get_strategy(name), city200, "paper") for name in ALL}


# -- registry ----------------------------------------------------------------------------------------

def test_registry_lists_every_strategy():
    assert list_strategies() == [*ALL, "ppo"]  # ppo's module (and torch) is imported when it is built
    for name in ALL:
        s = get_strategy(name)
        assert s.name == name
        assert isinstance(s.describe(), dict)


def test_each_strategy_carries_its_facts_and_the_package_reads_them():
    """A strategy is one module: the benchmark, the leaderboard, the figures and imitation read its class."""
    from hev_thermal_env.agents import register, strategy_class
    from hev_thermal_env.agents.base import Strategy
    from hev_thermal_env.evaluation.benchmark import DEFAULT_STRATEGIES
    from hev_thermal_env.evaluation.leaderboard import METHODS, label
    from hev_thermal_env.evaluation.score import display_name
    from hev_thermal_env.evaluation.styles import ordered, strategy_styles

    assert DEFAULT_STRATEGIES == (*ALL, "ppo")
    assert METHODS == (*ALL[1:], "ppo")  # conventional drives another bus
    assert ordered(["ppo", "dp_thermal", "x", "rule", "conventional"]) == ["conventional", "rule", "x", "dp_thermal",
                                                                           "ppo"]
    styles = strategy_styles(list(ALL))
    assert styles["dp"] == {"color": "#000000", "lw": 0.9, "zorder": 3, "ls": "-"}
    assert styles["dp_thermal"]["ls"] == "--" and "ls" not in styles["ecms"]
    assert len({st["color"] for st in styles.values()}) == len(ALL)
    assert display_name("dp:fine") == "dp:fine (thermal-blind)" and label("dp_thermal") == "dp_thermal (the optimum)"
    assert [n for n in list_strategies() if strategy_class(n).teacher] == list(ALL[:6])
    assert strategy_class("ppo:runs/x").learned and strategy_class("greedy") is None
    with pytest.raises(ValueError, match="taken"):
        register(type("Other", (Strategy,), {"name": "rule"}))


def test_unknown_strategy_lists_the_valid_ones():
    with pytest.raises(ValueError) as err:
        get_strategy("greedy")
    msg = str(err.value)
    assert "greedy" in msg
    for name in ALL:
        assert name in msg


def test_label_suffix_and_bad_options():
    s = get_strategy("dp:fine", n_soc=801)
    assert s.name == "dp" and s.label == "dp:fine" and s.settings.n_soc == 801
    with pytest.raises(ValueError, match="unknown option"):
        get_strategy("dp", n_socs=3)
    with pytest.raises(ValueError, match="penalty"):
        get_strategy("ecms", penalty="quartic")


# -- every strategy runs, metrics ------------------------------------------------------------------

@pytest.mark.parametrize("name", ALL)
def test_each_strategy_runs_the_short_cycle(runs, name):
    res = runs[name]
    s = res.summary
    for key in ("cycle", "strategy", "scenario", "distance_km", "fuel_g", "fuel_l_per_100km",
                "fuel_corrected_l_per_100km", "soc_correction_l_per_100km", "miss_correction_l_per_100km",
                "missed_wheel_energy_kwh", "soc_initial", "soc_final", "max_motor_temp_c", "heat_index_max",
                "derated_s", "cutoff_s", "trace_miss_max_mps", "wall_s", "strategy_settings"):
        assert key in s, key
    assert set(SUMMARY_KEYS) - {"conditions"} <= set(s)
    assert s["strategy"] == name and s["cycle"] == "beijing_200s" and s["scenario"] == "paper"
    assert np.isfinite(s["fuel_corrected_l_per_100km"]) and s["fuel_g"] > 0
    assert len(res.trace["soc"]) == 200
    json.dumps(res.to_json_dict())  # JSON-ready
    assert np.all(np.abs(res.trace["motor_share"]) <= 1.0)


def test_engine_only_is_the_hybrid_with_its_motor_unused(runs, city200):
    """u = 0 on the hybrid: no motor torque, no regeneration (the battery never charges), the same bus as the other
    hybrid strategies (the same road load at every step), the spinning motor's losses still drawn and heating it."""
    res, rule = runs["engine_only"].trace, runs["rule"].trace
    assert np.all(res["motor_share"] == 0.0)
    assert np.all(res["motor_torque_nm"] == 0.0)
    braking = res["shaft_torque_demand_nm"] < 0.0
    assert braking.sum() > 20 and np.all(res["brake_power_w"][braking] > 0.0)
    assert np.all(res["battery_power_w"] >= 0.0) and np.all(np.diff(res["soc"]) <= 0.0)
    np.testing.assert_array_equal(res["wheel_power_demand_w"], rule["wheel_power_demand_w"])
    assert np.all(res["motor_loss_w"][res["motor_speed_radps"] > 50.0] > 0.0)
    assert runs["engine_only"].summary["max_motor_temp_c"] > 20.0  # the spinning losses warm it from 20 °C
    sim = simulate(city200, config=paper_bus(), split=0.0)  # the metrics are the physics simulation's, u = 0
    assert runs["engine_only"].summary["fuel_g"] == pytest.approx(sim.summary["fuel_g"], rel=1e-12)
    assert runs["engine_only"].summary["soc_final"] == pytest.approx(sim.summary["soc_final"], abs=1e-12)


def test_conventional_is_another_vehicle(runs, city200):
    s = get_strategy("conventional")
    assert s.other_vehicle and not get_strategy("engine_only").other_vehicle
    assert "another vehicle" in s.describe()["vehicle"]
    res = runs["conventional"]
    assert np.all(res.trace["motor_torque_nm"] == 0.0) and np.all(res.trace["motor_loss_w"] == 0.0)
    assert res.summary["soc_final"] == res.summary["soc_initial"]
    sim = simulate(city200, config=paper_bus().conventional(), split=0.0)
    assert res.summary["fuel_g"] == pytest.approx(sim.summary["fuel_g"], rel=1e-12)
    assert res.summary["fuel_g"] != pytest.approx(runs["engine_only"].summary["fuel_g"], rel=1e-3)


def test_ordering_on_the_short_city_cycle(runs):
    """Corrected fuel: dp <= ecms <= rule <= engine_only, and dp_thermal <= ecms_thermal (same thermal model)."""
    f = {k: r.summary["fuel_corrected_l_per_100km"] for k, r in runs.items()}
    assert f["dp"] <= f["ecms"] <= f["rule"] <= f["engine_only"], f
    assert f["dp_thermal"] <= f["ecms_thermal"], f
    for name in ("dp", "dp_thermal", "ecms", "aecms"):
        assert abs(runs[name].summary["delta_soc"]) <= 0.02, (name, runs[name].summary["delta_soc"])


def test_ecms_within_3_percent_of_dp_on_the_short_cycle(runs):
    dp = runs["dp"].summary["fuel_corrected_l_per_100km"]
    for name in ("ecms", "aecms"):
        assert runs[name].summary["fuel_corrected_l_per_100km"] <= 1.03 * dp


# -- rule ------------------------------------------------------------------------------------------

class _EnvStub:
    """Only what RuleBased.engine_torque_nm reads."""

    def __init__(self):
        from hev_thermal_env.physics import PhysicsCore
        self.config = paper_bus()
        self.core = PhysicsCore(self.config)


def test_rule_follows_advisor_defaults():
    rule = RuleBased()
    env = _EnvStub()
    rule.env = env
    rule.charge_trq_nm = 0.25 * min(env.config.engine.max_torque_nm)  # what reset() sets
    assert rule.charge_trq_nm == pytest.approx(62.5)
    w = 200.0  # rad/s
    from hev_thermal_env.physics import engine as eng
    t_max = eng.max_torque_nm(env.core.en, w)
    # mid band: no charge torque, engine takes the demand
    assert rule.engine_torque_nm(100.0, w, 0.65, 10.0) == pytest.approx(100.0)
    # top of the band: the motor assists with the full charge torque
    assert rule.engine_torque_nm(100.0, w, 0.70, 10.0) == pytest.approx(100.0 - 62.5)
    # below lo: charge torque and at least min_trq_frac of full load
    assert rule.engine_torque_nm(10.0, w, 0.55, 10.0) == pytest.approx(max(10.0 + 62.5 * 2.0, 0.4 * t_max))
    # ADVISOR default keeps the engine on whenever the bus pulls (off_trq_frac 0, launch speed 0)
    assert rule.engine_torque_nm(1.0, w, 0.75, 0.0) is not None
    # with an electric launch below 5 m/s and SOC in the band, the engine stays off
    ev = RuleBased(launch_spd_lo_mps=5.0, launch_spd_hi_mps=5.0, off_trq_frac=0.5)
    ev.env, ev.charge_trq_nm = env, 62.5
    assert ev.engine_torque_nm(50.0, w, 0.65, 2.0) is None


def test_rule_regenerates_all_it_can_while_braking(runs):
    """ADVISOR's behaviour: u = 1 while braking, so the motor brakes with all the regeneration available and charges
    the battery; the motor-unused bus, on the same braking, charges nothing."""
    tr = runs["rule"].trace
    braking = tr["shaft_torque_demand_nm"] < 0.0
    assert np.all(tr["motor_share"][braking] == 1.0)
    np.testing.assert_allclose(tr["motor_torque_nm"][braking], tr["regen_available_nm"][braking], rtol=0, atol=1e-9)
    hard = braking & (tr["regen_available_nm"] < -100.0)
    assert hard.sum() > 5 and np.all(tr["battery_power_w"][hard] < 0.0)
    unused = runs["engine_only"].trace
    assert np.all(unused["battery_power_w"][hard] > 0.0)


def test_rule_charges_when_low_and_assists_when_high(city200):
    env = HevThermalEnv(cycle=city200, scenario="paper")
    for soc, sign in ((0.55, -1.0), (0.75, 1.0)):
        env.reset(seed=0, options={"initial_soc": soc})
        rule = RuleBased()
        rule.reset(env)
        us = []
        for _ in range(60):
            _, out = env.peek(np.zeros(1))
            u = float(rule.act(None, {})[0])
            if out[0, SHAFT_DEMAND] > 0:
                us.append(u)
            env.step(np.array([u], dtype=np.float32))
        assert us and sign * np.mean(us) > 0


# -- ECMS --------------------------------------------------------------------------------------------

def test_ecms_cost_is_fuel_plus_equivalent_battery_energy_plus_miss_price():
    from hev_thermal_env.physics import PhysicsCore
    core = PhysicsCore(paper_bus())
    cond = Conditions()
    n = 41
    st = core.initial_state(cond, n)
    u = np.linspace(-1, 1, n)
    so, out = core.step(st, u, np.full(n, 10.0), np.full(n, 10.5), np.zeros(n), core.conditions_array(cond, n))
    lhv = core.config.engine.fuel_lhv_j_per_g
    rp = RewardParams()
    s = 2.5
    cost = ecms_cost_g(out, so, s, lhv, rp)
    miss_price = stage_cost_g(rp, out, so, 0.0, lhv, 1.0, battery=False) - out[:, FUEL_G]
    assert np.all(miss_price >= 0.0)
    np.testing.assert_allclose(cost, out[:, FUEL_G] + s * out[:, BATT_CHEM] / lhv + miss_price, rtol=1e-12)
    # at the reward's equivalence factor the battery term is the reward's battery price
    full = stage_cost_g(rp, out, so, 0.0, lhv, 1.0)
    np.testing.assert_allclose(ecms_cost_g(out, so, REWARD_EQUIVALENCE_FACTOR, lhv, rp), full, rtol=1e-9)
    # a cheap battery favours assist, a dear one favours charging
    assert u[np.argmin(ecms_cost_g(out, so, 0.5, lhv, rp))] > 0.5
    assert u[np.argmin(ecms_cost_g(out, so, 6.0, lhv, rp))] < 0.0


def test_ecms_soc_penalty_and_aecms_pi():
    e = ECMS(s=3.0, k_soc=1.0, penalty="linear")
    e.soc_target = 0.65
    assert e.equivalence_factor(0.60) > 3.0 > e.equivalence_factor(0.70)
    c = ECMS(s=3.0, k_soc=1.0, penalty="cubic")
    c.soc_target = 0.65
    assert c.equivalence_factor(0.65) == 3.0 and c.equivalence_factor(0.55) == pytest.approx(6.0)
    a = AdaptiveECMS(s0=3.0, kp=20.0, ki=0.01)
    a.soc_target, a.dt_s, a.integral = 0.65, 1.0, 0.0
    for _ in range(100):
        a._observe(0.60)
    assert a.integral == pytest.approx(5.0)
    assert a.equivalence_factor(0.60) == pytest.approx(3.0 + 20.0 * 0.05 + 0.01 * 5.0)


def test_ecms_regenerates_fully_and_ecms_thermal_less_when_the_motor_is_hot():
    """Braking from 54 km/h: ECMS takes all the available regeneration, cold or hot; with the motor hot, the thermal
    ECMS at physics v1's heat prices takes a smaller share (its price on the next temperature and heat index)."""
    cyc = cycle_from_arrays(np.linspace(15.0, 0.0, 40), name="stop")
    shares = {}
    for temp in (20.0, 66.0):
        cond = Conditions(ambient_temp_c=40.0, initial_motor_temp_c=temp, coolant="off")
        for name in ("ecms", "ecms_thermal"):
            options = THERMAL_PRICES[1] if name == "ecms_thermal" else {}
            tr = run_strategy(get_strategy(name, **options), cyc, "paper", conditions=cond).trace
            regen = tr["regen_available_nm"] < -10.0
            assert regen.sum() > 20
            shares[name, temp] = tr["motor_share"][regen]
    assert np.all(shares["ecms", 20.0] == 1.0) and np.all(shares["ecms", 66.0] == 1.0)
    assert np.all(shares["ecms_thermal", 20.0] == 1.0)
    assert np.mean(shares["ecms_thermal", 66.0]) < 0.9


def test_ecms_thermal_takes_its_physics_versions_heat_prices():
    """Left out, ``w_x``, ``x_thr`` and ``w_temp`` follow the env's physics version at reset (v1: 300 g from
    x = -0.05 and 5 g/K²; v2: 30 g on the heat index itself, no temperature price); given, they stay. On physics v2,
    where the heat index stays 0 (a cool motor on a short cycle), ecms_thermal drives exactly as ecms; where the
    heat index rises, it derates less."""
    udds = load_cycle("udds")
    cyc = cycle_from_arrays(udds.speed_mps[:400], name="udds-400")
    for physics in (1, 2):
        s = get_strategy("ecms_thermal")
        run_strategy(s, cyc, "paper", physics=physics)
        assert (s.w_x, s.x_thr, s.w_temp) == tuple(THERMAL_PRICES[physics][k] for k in ("w_x", "x_thr", "w_temp"))
        given = get_strategy("ecms_thermal", w_x=7.0)
        run_strategy(given, cyc, "paper", physics=physics)
        assert given.w_x == 7.0 and given.x_thr == THERMAL_PRICES[physics]["x_thr"]
    cool = {n: run_strategy(get_strategy(n), cyc, "paper", physics=2).trace for n in ("ecms", "ecms_thermal")}
    assert np.all(cool["ecms"]["heat_index"] == 0.0)
    np.testing.assert_array_equal(cool["ecms"]["u"], cool["ecms_thermal"]["u"])
    hot = Conditions(ambient_temp_c=40.0, initial_motor_temp_c=60.0, coolant_temp_c=60.0, coolant="degraded",
                     coolant_degraded_factor=0.1, payload_kg=4500.0)
    runs = {n: run_strategy(get_strategy(n), cyc, "paper", conditions=hot, physics=2).summary
            for n in ("ecms", "ecms_thermal")}
    assert runs["ecms"]["derated_s"] > 0
    assert runs["ecms_thermal"]["derated_s"] < runs["ecms"]["derated_s"]


def test_ecms_thermal_holds_back_a_hot_motor():
    """A launch and a minute's cruise at 69 °C with a full battery (SOC 0.75 against a target of 0.65, so assisting is
    cheap): the plain ECMS assists into the cutoff, the thermal ECMS at physics v1's heat prices (its price on the
    temperature above 55 °C) asks the motor for less and avoids it."""
    cyc = cycle_from_arrays(np.r_[np.linspace(0.0, 15.0, 40), np.full(60, 15.0)], name="launch")
    cond = Conditions(ambient_temp_c=40.0, initial_motor_temp_c=69.0, coolant="off", initial_soc=0.75)
    runs = {name: run_strategy(get_strategy(name, soc_target=0.65, **(THERMAL_PRICES[1] if name == "ecms_thermal"
                                                                      else {})), cyc, "paper", conditions=cond)
            for name in ("ecms", "ecms_thermal")}
    assert runs["ecms"].summary["cutoff_s"] > 10 and runs["ecms_thermal"].summary["cutoff_s"] == 0
    torques = {name: np.abs(r.trace["motor_torque_nm"][:40]).sum() for name, r in runs.items()}  # before any cutoff
    assert torques["ecms_thermal"] < 0.8 * torques["ecms"]


# -- plots and the run command -------------------------------------------------------------------------

def test_plot_run_overlays_strategies(runs, tmp_path):
    path = plot_run({k: runs[k].trace for k in ("rule", "ecms", "dp")}, tmp_path / "p.png", title="t")
    assert path.exists() and path.stat().st_size > 10_000


def test_evaluate_run_end_to_end(tmp_path):
    csv = tmp_path / "tiny.csv"
    cycle_from_arrays(load_cycle("beijing").speed_mps[:61], name="tiny").to_csv(csv)
    out_json, out_csv, out_png = tmp_path / "r.json", tmp_path / "r.csv", tmp_path / "r.png"
    r = subprocess.run([sys.executable, str(ROOT / "evaluate.py"), "run", "--cycle", str(csv), "--strategy", "dp",
                        "--dp-soc-points", "51", "--dp-actions", "11", "--dp-on-infeasible", "closest",
                        "--json", str(out_json), "--trace", str(out_csv), "--plot", str(out_png)],
                       capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "corrected fuel" in r.stdout and "L/100 km" in r.stdout
    data = json.loads(out_json.read_text())
    assert data["strategy"] == "dp" and data["strategy_settings"]["grid"] == {"soc": 51}
    assert data["strategy_settings"]["n_u"] == 11
    lines = out_csv.read_text().splitlines()
    assert len(lines) == 61 and lines[0].startswith("fuel_g,soc,motor_temp_c,heat_index")
    assert out_png.stat().st_size > 10_000


@pytest.mark.parametrize("args, listed", [
    (["--cycle", "beijing", "--strategy", "greedy"], ["engine_only", "ecms_thermal", "dp_thermal"]),
    (["--cycle", "beijing", "--strategy", "rule", "--scenario", "arctic"], ["paper", "hot", "random"]),
    (["--cycle", "mars", "--strategy", "rule"], ["hwfet", "beijing"]),
    (["--cycle", "beijing", "--strategy", "rule", "--dp-soc-points", "101"], ["dp", "dp_thermal"]),
    (["--cycle", "beijing", "--strategy", "dp_thermal", "--dp-soc-points", "101"], ["dp", "--dp-grid-scale"]),
])
def test_evaluate_run_bad_input(args, listed, capsys):
    sys.path.insert(0, str(ROOT))
    try:
        import evaluate
    finally:
        sys.path.pop(0)
    assert evaluate.main(["run", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "Traceback" not in err
    for name in listed:
        assert name in err


def test_ecms_thermal_margin_prices_the_heat_index_by_the_distance_to_the_cutoff():
    """``x_price="margin"``: w_x within the cutoff's hysteresis band (10 K), w_x·10/(T_cut − T) below it; on a hilly
    road in the paper's conditions (a cool motor) it derates for fuel where the fixed price holds back, and on a
    failing cooling loop it still keeps the motor from the cutoff."""
    env = HevThermalEnv(cycle=cycle_from_arrays(np.full(20, 10.0), name="cruise"))
    env.reset(seed=0)
    agent, fixed = get_strategy("ecms_thermal", x_price="margin", w_x=300.0), get_strategy("ecms_thermal", w_x=300.0)
    agent.reset(env)
    fixed.reset(env)
    for temp_c, price in ((20.0, 60.0), (50.0, 150.0), (60.0, 300.0), (69.0, 300.0), (75.0, 300.0)):
        env.phys_state[0, TEMP_C] = temp_c
        assert agent.heat_index_price() == pytest.approx(price) and fixed.heat_index_price() == 300.0
    # margin_floor: the price in a cool motor never below that share of w_x; the hot price unchanged
    floored = get_strategy("ecms_thermal", x_price="margin", w_x=300.0, margin_floor=0.5)
    floored.reset(env)
    for temp_c, price in ((20.0, 150.0), (40.0, 150.0), (50.0, 150.0), (55.0, 200.0), (60.0, 300.0), (75.0, 300.0)):
        env.phys_state[0, TEMP_C] = temp_c
        assert floored.heat_index_price() == pytest.approx(price)
    # braking_floor: while the bus brakes, that floor instead (default: margin_floor's)
    assert floored.braking_floor == 0.5
    braked = get_strategy("ecms_thermal", x_price="margin", w_x=300.0, margin_floor=0.5, braking_floor=1.0)
    braked.reset(env)
    for temp_c, traction, braking in ((20.0, 150.0, 300.0), (55.0, 200.0, 300.0), (75.0, 300.0, 300.0)):
        env.phys_state[0, TEMP_C] = temp_c
        assert braked.heat_index_price() == pytest.approx(traction)
        assert braked.heat_index_price(braking=True) == pytest.approx(braking)
        assert floored.heat_index_price(braking=True) == floored.heat_index_price()
    for bad in (-0.1, 1.5):
        with pytest.raises(ValueError, match="margin_floor must lie in \\[0, 1\\]"):
            get_strategy("ecms_thermal", x_price="margin", margin_floor=bad)
        with pytest.raises(ValueError, match="braking_floor must lie in \\[0, 1\\]"):
            get_strategy("ecms_thermal", x_price="margin", braking_floor=bad)
    with pytest.raises(ValueError, match="braking_floor applies to x_price='margin'"):
        get_strategy("ecms_thermal", braking_floor=1.0)
    with pytest.raises(ValueError, match="margin_floor applies to x_price='margin'"):
        get_strategy("ecms_thermal", margin_floor=0.5)
    with pytest.raises(ValueError, match="x_price 'cheap' is not one of"):
        get_strategy("ecms_thermal", x_price="cheap")
    runs = {p: run_strategy(get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price=p), "udds", "hilly").summary
            for p in ("fixed", "margin")}
    assert runs["margin"]["fuel_corrected_l_per_100km"] < 0.99 * runs["fixed"]["fuel_corrected_l_per_100km"]
    assert runs["margin"]["safety_cost_s"] > runs["fixed"]["safety_cost_s"] and runs["margin"]["cutoff_s"] == 0
    hot = run_strategy(get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price="margin"), "udds", "hot").summary
    assert hot["cutoff_s"] == 0 and hot["safety_cost_s"] < 1.0


def _stop(cruise_s: int, stop_s: int) -> tuple[HevThermalEnv, int]:
    """An env reset on a cruise at 72 km/h for ``cruise_s`` seconds, then a stop over ``stop_s`` samples; the number
    of steps it drives."""
    speeds = np.concatenate([np.full(cruise_s, 20.0), np.linspace(20.0, 0.0, stop_s)])
    env = HevThermalEnv(cycle=cycle_from_arrays(speeds, name="stop"))
    env.reset(seed=0)
    return env, len(speeds) - 1


def test_ecms_thermal_prices_regeneration_from_its_own_threshold():
    """``braking_x_thr``: while the bus brakes the heat index is priced from that x on (0: only the regeneration that
    derates), in traction from ``x_thr``; the price's floor is ``braking_floor`` while braking. The costs are compared
    candidate by candidate against a teacher without the braking options, on the same peeked step."""
    env, steps = _stop(cruise_s=5, stop_s=11)
    plain = get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price="margin", margin_floor=0.5)
    braked = get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price="margin", margin_floor=0.5,
                          braking_floor=1.0, braking_x_thr=0.0)
    thr_only = get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price="margin", margin_floor=0.5, braking_x_thr=0.0)
    for agent in (plain, braked, thr_only):
        agent.reset(env)
    seen = {"traction": 0, "braking": 0, "derating": 0}
    for _ in range(steps):
        if env.peek(plain.u_grid)[1][0, SHAFT_DEMAND] == 0.0:
            break
        # below 0 every candidate stays short of derating; above it the regenerating ones derate
        for x0 in (-0.02, 0.02):
            env.phys_state[0, HEAT_X] = x0
            st, out = env.peek(plain.u_grid)
            soc = float(env.phys_state[0, SOC])
            x_new = st[:, HEAT_X]
            gap = braked.candidate_costs(st, out, soc) - plain.candidate_costs(st, out, soc)
            if out[0, SHAFT_DEMAND] > 0.0:
                assert np.array_equal(gap, np.zeros_like(gap))
                seen["traction"] += 1
                continue
            price_plain, price_braked = plain.heat_index_price(braking=True), braked.heat_index_price(braking=True)
            expected = price_braked * np.maximum(x_new, 0.0) - price_plain * np.maximum(x_new + 0.05, 0.0)
            np.testing.assert_allclose(gap, expected, atol=1e-9)
            assert np.any(np.abs(gap) > 1e-6)  # the two prices differ on this step
            assert price_braked == pytest.approx(300.0) and price_plain == pytest.approx(150.0)
            # the floor alone: the whole w_x against half of it, on the candidates that derate
            floor_gap = braked.candidate_costs(st, out, soc) - thr_only.candidate_costs(st, out, soc)
            np.testing.assert_allclose(floor_gap, 150.0 * np.maximum(x_new, 0.0), atol=1e-9)
            seen["braking"] += 1
            seen["derating"] += int(np.any(x_new > 0.0))
        env.step(np.array([1.0], dtype=np.float32))
    assert seen["traction"] > 0 and seen["braking"] > 0 and seen["derating"] > 0
    with pytest.raises(ValueError, match="braking_x_thr must lie in \\[-0.3, 0\\]"):
        get_strategy("ecms_thermal", **THERMAL_PRICES[1], x_price="margin", braking_x_thr=0.1)
    with pytest.raises(ValueError, match="braking_below_c must be a finite temperature"):
        get_strategy("ecms_thermal", braking_below_c=float("nan"))
    assert get_strategy("ecms_thermal", x_thr=-0.5).braking_x_thr == -0.5  # the default follows x_thr, unchecked


def test_ecms_thermal_braking_options_only_below_a_temperature():
    """``braking_below_c``: the braking threshold and floor hold only while the motor is cooler than that; a hotter
    motor's regeneration is priced as in traction (its approach to derating too)."""
    env, steps = _stop(cruise_s=3, stop_s=9)
    opts = {"x_price": "margin", "margin_floor": 0.5}
    plain = get_strategy("ecms_thermal", **opts)
    always = get_strategy("ecms_thermal", **opts, braking_floor=1.0, braking_x_thr=0.0)
    cool = get_strategy("ecms_thermal", **opts, braking_floor=1.0, braking_x_thr=0.0, braking_below_c=50.0)
    for agent in (plain, always, cool):
        agent.reset(env)
    assert cool.describe()["braking_below_c"] == 50.0 and always.describe()["braking_below_c"] is None
    braked = 0
    for _ in range(steps):
        st, out = env.peek(plain.u_grid)
        if out[0, SHAFT_DEMAND] < 0.0:
            soc = float(env.phys_state[0, SOC])
            for temp_c, like in ((40.0, always), (55.0, plain)):
                env.phys_state[0, TEMP_C] = temp_c
                env.phys_state[0, HEAT_X] = -0.02
                st, out = env.peek(plain.u_grid)
                np.testing.assert_array_equal(cool.candidate_costs(st, out, soc), like.candidate_costs(st, out, soc))
                assert cool.heat_index_terms(braking=True) == like.heat_index_terms(braking=True)
            braked += 1
        env.step(np.array([1.0], dtype=np.float32))
    assert braked > 0


def test_run_strategy_drives_the_vehicle_it_is_given():
    """``run_strategy(config=)`` drives that bus: 3 t more test mass burns more fuel on the same cycle and split."""
    bus = paper_bus()
    heavy = bus.replace(glider=bus.glider.replace(mass_kg=bus.glider.mass_kg + 3000.0))
    cycle = cycle_from_arrays(load_cycle("udds").speed_mps[:201], name="udds_200s")
    light_run = run_strategy(get_strategy("engine_only"), cycle, "paper").summary
    heavy_run = run_strategy(get_strategy("engine_only"), cycle, "paper", config=heavy).summary
    assert heavy_run["fuel_g"] > 1.05 * light_run["fuel_g"]
    assert heavy_run["distance_km"] == pytest.approx(light_run["distance_km"], rel=1e-3)
