#!/usr/bin/env python
"""The optimum of the env's default reward is charge-sustaining, and its return is the corrected fuel.

For every cycle (HWFET, Beijing, UDDS and two routes of more than 3,000 s: a generated bus route
and HWFET + UDDS + Beijing back to back), ``paper`` scenario, this runs dynamic programming over
the SOC in the environment and records, per run, the final ΔSOC, the corrected fuel, its ratio to
the fixed-band DP, the episode's return and the check that the fuel + miss + SOC terms of the
return equal minus the corrected fuel:

* ``dp_fixed_band``: the benchmark's ``dp`` (final SOC = initial ± 0.005, the SOC terms not priced);
* ``reward_default``: DP minimising the whole default reward (``price_soc_deviation=True``) with
  the final SOC free (``soc_tol=0.3``: the band spans the battery's whole window): the optimum of
  the reward a user trains on;
* ``reward_default_band_dp``: the same reward with the final SOC held in the settlement's band
  (``soc_tol=soc_band``), where the settlement adds up to zero: the reward's optimum whenever the
  free run ends inside the band. The free run's SOC grid spans the whole window (401 points, 0.001
  SOC apart), the band run's only the corridor into the band, so the band run is the finer
  solution of the same problem (the free run ends a little short of the band's edge, a few
  hundredths of a percent higher in corrected fuel);
* ``reward_old_default``: the same for a reward without the band settlement, a quadratic tether
  (``soc_deviation_weight=0.2``) only;
* ``prices_only``: the same with no SOC term at all (fuel + miss + battery energy at the stated
  prices): where the price mismatch alone takes the SOC.

And, per cycle, the marginal value of ending with more or less charge than the band allows:
fixed-band DP plans (planned cost, SOC terms not priced) for final SOCs at the band's edges and
0.02 beyond them; (cost at the edge − cost beyond) / 0.02 is what one unit of SOC beyond the band
earns at the stated prices, to be compared with ``soc_band_weight``.

Usage::

    python benchmarks/reward_optimum.py             # writes benchmarks/results/reward_optimum.json
    python benchmarks/reward_optimum.py --quick     # UDDS only, coarse grids
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from hev_thermal_env import cycle_from_arrays, load_cycle
from hev_thermal_env.agents import get_strategy
from hev_thermal_env.cycles import Cycle
from hev_thermal_env.cycles.generator import generate_bus_cycle
from hev_thermal_env.envs.hev_env import HevThermalEnv
from hev_thermal_env.envs.reward import RewardParams
from hev_thermal_env.metrics import run_metrics
from hev_thermal_env.physics import core

DEFAULT_JSON = Path(__file__).resolve().parent / "results" / "reward_optimum.json"
LIMIT_DELTA_SOC = 0.02
ROUTE_SEED = 2024
FREE = {"soc_tol": 0.3, "price_soc_deviation": True}  # final SOC free: the band spans the battery's window
#: label: (reward of the env, DP options)
RUNS = {
    "dp_fixed_band": (None, {}),
    "reward_default": (RewardParams(), FREE),
    "reward_default_band_dp": (RewardParams(), {"soc_tol": RewardParams().soc_band, "price_soc_deviation": True}),
    "reward_old_default": (RewardParams(soc_band_weight=0.0, soc_deviation_weight=0.2), FREE),
    "prices_only": (RewardParams(soc_band_weight=0.0, soc_deviation_weight=0.0), FREE),
}


def cycles(quick: bool) -> list[Cycle]:
    """The cycles of the study: three standard ones and two routes of more than 3,000 s."""
    if quick:
        return [load_cycle("udds")]
    base = [load_cycle(name) for name in ("hwfet", "beijing", "udds")]
    route = generate_bus_cycle(ROUTE_SEED, duration_s=3600.0, name="bus_route_3600s")
    joined = np.concatenate([base[0].speed_mps] + [c.speed_mps[1:] for c in (base[2], base[1])])
    mixed = cycle_from_arrays(joined, name="hwfet_udds_beijing", description="HWFET, UDDS, Beijing back to back")
    return [*base, route, mixed]


def drive(cycle: Cycle, reward: RewardParams | None, dp_options: dict) -> dict:
    """DP with ``dp_options`` driving ``cycle`` in an env with ``reward``; metrics, return and the honesty check."""
    t0 = time.perf_counter()
    env = HevThermalEnv(cycle=cycle, scenario="paper", reward=reward)
    obs, info = env.reset(seed=0)
    strategy = get_strategy("dp", **dp_options)
    strategy.reset(env)
    n = env.cycle.n_steps
    outs, states = np.empty((n, core.N_OUT)), np.empty((n, core.N_STATE))
    terms = np.zeros(4)
    for k in range(n):
        obs, _, _, truncated, info = env.step(strategy.act(obs, info))
        outs[k], states[k] = env.last_out, env.phys_state[0]
        terms += [info["reward_fuel"], info["reward_miss"], info["reward_soc"], info["reward_overheat"]]
    trace = {name: outs[:, i] for i, name in enumerate(core.OUT_NAMES)}
    trace.update({name: states[:, i] for i, name in enumerate(core.STATE_NAMES)})
    trace["heat_index"] = np.clip(trace["heat_x"], 0.0, 1.0)
    soc0 = env.soc_target
    m = run_metrics(trace, env.config, soc0, env.cycle.speed_mps, 0, n, env.core.dt_s)
    corrected_g = m["fuel_corrected_l_per_100km"] * env.config.engine.fuel_density_kg_per_l * m["distance_km"] * 10.0
    d = strategy.describe()
    return {
        "delta_soc": m["delta_soc"],
        "soc_min": float(states[:, core.SOC].min()), "soc_max": float(states[:, core.SOC].max()),
        "fuel_corrected_l_per_100km": m["fuel_corrected_l_per_100km"], "fuel_l_per_100km": m["fuel_l_per_100km"],
        "corrected_fuel_g": corrected_g, "return_g": float(terms.sum()),
        "fuel_miss_soc_terms_g": float(terms[:3].sum()), "overheat_terms_g": float(terms[3]),
        "return_plus_corrected_fuel_g": float(terms[:3].sum() + corrected_g),
        "solve_s": d.get("solve_s"), "soc_band_used": d.get("soc_band_used"), "wall_s": time.perf_counter() - t0,
    }


def marginal_values(cycle: Cycle, band: float, grid: dict) -> dict:
    """What one unit of SOC beyond the band earns at the stated prices (fixed-band DP plans, g per unit SOC)."""
    env = HevThermalEnv(cycle=cycle, scenario="paper")
    env.reset(seed=0)
    target = env.soc_target

    def planned(soc_final: float) -> float:
        dp = get_strategy("dp", soc_final=soc_final, soc_tol=0.0005, on_infeasible="closest", **grid)
        dp.reset(env)
        return float(dp.describe()["planned_cost_g"])

    step = 0.02
    up_edge, up_beyond = planned(target + band), planned(target + band + step)
    down_edge, down_beyond = planned(target - band), planned(target - band - step)
    return {"charging_g_per_soc": (up_edge - up_beyond) / step,
            "discharging_g_per_soc": (down_edge - down_beyond) / step}


def study(quick: bool) -> dict:
    grid = {"n_soc": 101, "n_u": 11, "n_u_exec": 21} if quick else {"n_soc": 401, "n_u": 41}
    band = RewardParams().soc_band
    rows: dict = {}
    for cycle in cycles(quick):
        row: dict = {"duration_s": cycle.duration_s}
        for label, (reward, options) in RUNS.items():
            row[label] = drive(cycle, reward, {**grid, "on_infeasible": "closest", **options})
            fixed = row["dp_fixed_band"]["fuel_corrected_l_per_100km"]
            row[label]["fuel_vs_fixed_band_pct"] = 100.0 * row[label]["fuel_corrected_l_per_100km"] / fixed
            r = row[label]
            print(f"{cycle.name:>20} {label:>19}: dSOC {r['delta_soc']:+.4f}, corrected "
                  f"{r['fuel_corrected_l_per_100km']:.4f} L/100 km ({r['fuel_vs_fixed_band_pct']:.2f} % of fixed "
                  f"band), "
                  f"return + corrected fuel {r['return_plus_corrected_fuel_g']:+.3e} g", flush=True)
        row["marginal_value"] = marginal_values(cycle, band, grid)
        print(f"{cycle.name:>20} marginal value beyond the band (g per unit SOC): {row['marginal_value']}", flush=True)
        rows[cycle.name] = row
    return rows


def checks(rows: dict) -> dict:
    default = [r["reward_default"] for r in rows.values()]
    in_band = [r[label] for r in rows.values() for label in ("reward_default", "reward_default_band_dp")
               if abs(r[label]["delta_soc"]) <= RewardParams().soc_band]
    weight = RewardParams().soc_band_weight
    earning = max(max(r["marginal_value"].values()) for r in rows.values())  # > 0: going beyond the band pays
    return {
        "default_optimum_max_abs_delta_soc": max(abs(r["delta_soc"]) for r in default),
        "default_optimum_charge_sustaining": all(abs(r["delta_soc"]) <= LIMIT_DELTA_SOC for r in default),
        "old_default_max_abs_delta_soc": max(abs(r["reward_old_default"]["delta_soc"]) for r in rows.values()),
        "runs_ending_in_the_band": len(in_band),
        "default_return_is_minus_corrected_fuel_in_the_band": all(
            abs(r["return_plus_corrected_fuel_g"]) <= 1e-9 * r["corrected_fuel_g"] for r in in_band),
        "soc_band_weight_g_per_soc": weight,
        "largest_earning_beyond_the_band_g_per_soc": earning,
        "soc_band_weight_over_largest_earning": weight / earning,
    }


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, default=None,
                    help=f"output file (default {DEFAULT_JSON}; with --quick reward_optimum_quick.json next to it)")
    ap.add_argument("--quick", action="store_true", help="UDDS only, coarse DP grids (seconds)")
    args = ap.parse_args(argv)
    if args.json is None:
        args.json = DEFAULT_JSON.with_name("reward_optimum_quick.json") if args.quick else DEFAULT_JSON
    t0 = time.perf_counter()
    rows = study(args.quick)
    result = {
        "scenario": "paper", "limit_abs_delta_soc": LIMIT_DELTA_SOC, "quick": args.quick,
        "reward_default": RewardParams().to_dict(), "cycles": rows, "checks": checks(rows),
        "wall_s": time.perf_counter() - t0,
        "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count(),
                    "processor": platform.processor() or platform.machine()},
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(result, indent=2) + "\n")
    for key, value in result["checks"].items():
        print(f"{key}: {value}")
    print(f"wrote {args.json}")
    return result


if __name__ == "__main__":
    main()
