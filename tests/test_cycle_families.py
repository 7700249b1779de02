"""Cycle families, the validation set and their names: statistics within the documented bounds, determinism,
seeds disjoint from training, loading by name wherever cycles are accepted."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hev_thermal_env.cycles import (
    ImplausibleCycleWarning,
    cycle_statistics,
    expand_cycle_names,
    generate_bus_cycle,
    generate_family_cycle,
    list_families,
    load_cycle,
)
from hev_thermal_env.cycles.cycle import warn_implausible
from hev_thermal_env.cycles.families import (
    LAUNCH_ACCEL_MPS2,
    TRAINING_SEED_LIMIT,
    VALIDATION_SEED_BASE,
    inner_seed,
    training_seed,
)
from hev_thermal_env.cycles.generator import BEIJING_SEED
from hev_thermal_env.cycles.names import VALIDATION_FAMILIES, VALIDATION_SIZE, validation_cycle
from hev_thermal_env.envs import HevThermalEnv
from hev_thermal_env.physics.config import VehicleConfig
from hev_thermal_env.scenarios import get_scenario
from tools.family_bounds import FAMILY_BOUNDS

SEEDS = (0, 1, 7, 123_456, 2_000_000_000)


def within(value: float, bounds: tuple[float, float], tol: float = 1e-4) -> bool:
    return bounds[0] - tol <= value <= bounds[1] + tol


@pytest.mark.parametrize("family", list(FAMILY_BOUNDS))
def test_family_statistics_lie_within_the_documented_bounds(family):
    for seed in SEEDS:
        cyc = generate_family_cycle(family, seed)
        stats = cycle_statistics(cyc)
        for key, bounds in FAMILY_BOUNDS[family].items():
            assert within(stats[key], bounds), (family, seed, key, stats[key], bounds)
        assert cyc.speed_mps[0] == 0.0 and cyc.speed_mps[-1] == 0.0 and cyc.synthetic
        with warnings.catch_warnings():
            warnings.simplefilter("error", ImplausibleCycleWarning)
            warn_implausible(cyc.time_s, cyc.speed_mps, origin=cyc.name)


def test_every_family_is_documented_with_bounds():
    assert set(FAMILY_BOUNDS) == set(list_families())
    assert FAMILY_BOUNDS["bus_long"]["duration_s"][0] >= 3000
    assert FAMILY_BOUNDS["bus_congested"]["mean_speed_kmh"][1] <= 10
    assert FAMILY_BOUNDS["bus_launch"]["max_accel_mps2"][0] >= 1.3


@pytest.mark.parametrize("seed", SEEDS)
def test_hard_launches_reach_their_drawn_acceleration(seed):
    cyc = generate_family_cycle("bus_launch", seed)
    (segment,) = cyc.metadata["segments"]
    drawn = segment["params"]["max_accel_mps2"]
    assert LAUNCH_ACCEL_MPS2[0] <= drawn <= LAUNCH_ACCEL_MPS2[1]
    accel = np.diff(cyc.speed_mps)
    assert accel.max() >= 0.95 * drawn  # the launches do reach it, not only the limit
    starts = np.flatnonzero((cyc.speed_mps[:-3] == 0.0) & (cyc.speed_mps[3:] > 0.0))
    assert np.mean(accel[starts + 2] > 1.2) > 0.5  # most launches run above 1.2 m/s² within 3 s of standstill


def test_long_and_congested_are_what_they_say():
    for seed in SEEDS:
        assert generate_family_cycle("bus_long", seed).duration_s >= 3000.0
        assert generate_family_cycle("bus_mixed", seed).duration_s >= 3000.0
        congested = cycle_statistics(generate_family_cycle("bus_congested", seed))
        assert congested["mean_speed_kmh"] < 10.0 and congested["stops_per_km"] > 8.0
    hills = [cycle_statistics(generate_family_cycle("bus_hilly", s)) for s in SEEDS]
    assert all(h["grade_max"] > 0.01 and h["grade_min"] < -0.01 for h in hills)


@pytest.mark.parametrize("seed", SEEDS)
def test_express_routes_hold_motorway_stretches_the_engine_alone_cannot_follow(seed):
    cyc = generate_family_cycle("bus_express", seed)
    kinds = [seg["kind"] for seg in cyc.metadata["segments"]]
    assert kinds == ["city", "motorway", "city"]
    motorway_s = cyc.metadata["segments"][1]["duration_s"]
    assert 0.6 * cyc.duration_s - 1 <= motorway_s <= 0.75 * cyc.duration_s + 1
    v = np.asarray(cyc.speed_mps)
    assert np.mean(v > 60 / 3.6) > 0.3  # a third of the route at motorway speed
    bus = VehicleConfig()
    mass_kg, engine_w = bus.glider.mass_kg, bus.engine.max_power_w
    wheel_w = mass_kg * np.diff(v) * v[1:]  # inertial power alone, without drag and rolling resistance
    assert np.sum(wheel_w > engine_w) >= 5  # on-ramps and overtaking beyond the engine: motor-limited stretches


@pytest.mark.parametrize("family", ["bus_long", "bus_hilly", "bus_mixed", "random_bus"])
def test_same_seed_same_cycle_other_seed_other_cycle(family):
    a, b, c = (generate_family_cycle(family, s) for s in (5, 5, 6))
    np.testing.assert_array_equal(a.speed_mps, b.speed_mps)
    np.testing.assert_array_equal(a.grade, b.grade)
    assert a.metadata == b.metadata
    assert len(a.speed_mps) != len(c.speed_mps) or not np.array_equal(a.speed_mps, c.speed_mps)


def test_random_bus_family_is_the_generator_as_it_was():
    np.testing.assert_array_equal(generate_family_cycle("random_bus", 42).speed_mps, generate_bus_cycle(42).speed_mps)


def test_names_load_the_same_cycle_and_round_trip_through_csv(tmp_path):
    cyc = load_cycle("bus_mixed:11")
    assert cyc.name == "bus_mixed:11"
    np.testing.assert_array_equal(cyc.speed_mps, generate_family_cycle("bus_mixed", 11).speed_mps)
    again = load_cycle(cyc.to_csv(tmp_path / "mixed.csv"))
    np.testing.assert_array_equal(again.speed_mps, cyc.speed_mps)
    np.testing.assert_array_equal(again.grade, cyc.grade)


def test_bad_generated_names_fail_in_one_line():
    with pytest.raises(ValueError, match="family of generated cycles"):
        load_cycle("bus_long")
    with pytest.raises(ValueError, match="set of cycles"):
        load_cycle("validation_bus")
    with pytest.raises(ValueError, match="0-29"):
        load_cycle(f"validation_bus:{VALIDATION_SIZE}")
    with pytest.raises(ValueError, match="unknown cycle"):
        load_cycle("bus_nowhere:3")
    with pytest.raises(ValueError, match="range"):
        expand_cycle_names("bus_long:5..2")


# --- the validation set ---------------------------------------------------------------------------

def test_validation_set_name_loads_at_least_20_long_congested_hilly_cycles():
    names = expand_cycle_names("validation_bus")
    assert len(names) == VALIDATION_SIZE >= 20 and len(set(names)) == len(names)
    cycles = [load_cycle(n) for n in names]
    families = [c.metadata["family"] for c in cycles]
    assert set(families[:25]) == set(VALIDATION_FAMILIES) >= {"bus_long", "bus_congested", "bus_hilly"}
    assert set(families[25:]) == {"bus_express"}  # the express routes follow the rotation of five
    assert expand_cycle_names(["validation_bus:0..4"]) == names[:5]
    assert {c.metadata["family"] for c in cycles[:5]} == set(VALIDATION_FAMILIES)  # the quick subset: one each
    np.testing.assert_array_equal(cycles[3].speed_mps, validation_cycle(3).speed_mps)


def test_validation_seeds_are_disjoint_from_every_training_seed():
    val_seeds = [load_cycle(n).metadata["seed"] for n in expand_cycle_names("validation_bus")]
    assert min(val_seeds) >= VALIDATION_SEED_BASE > TRAINING_SEED_LIMIT
    rng = np.random.default_rng(0)
    drawn = [training_seed(rng, f) for f in list_families() for _ in range(2000)]
    assert max(drawn) < TRAINING_SEED_LIMIT
    # the generator seeds of the segments and roads: injective in (family, seed, part), so disjoint too
    val_inner = {s["seed"] for n in expand_cycle_names("validation_bus") for s in load_cycle(n).metadata["segments"]}
    train_inner = {inner_seed(f, s, p) for f in list_families() if f != "random_bus" for s in drawn[:200]
                   for p in range(1, 8)}
    assert not val_inner & train_inner
    assert min(val_inner) > 2**48 > TRAINING_SEED_LIMIT  # and none is a random_bus or built-in seed


def test_training_never_draws_beijing():
    class Always171:
        def integers(self, *args):
            self.calls = getattr(self, "calls", 0) + 1
            return BEIJING_SEED if self.calls == 1 else 5

    assert training_seed(Always171(), "random_bus") == 5
    assert training_seed(Always171(), "bus_long") == BEIJING_SEED  # other families: 171 is just a seed


def test_env_draws_family_cycles_and_payload_per_episode():
    env = HevThermalEnv(cycle=["bus_congested", "bus_launch"], scenario="random_service", random_start=True)
    seen, payloads = set(), set()
    for seed in range(8):
        env.reset(seed=seed)
        seen.add(env.cycle.metadata["family"])
        payloads.add(round(env.conditions.payload_kg, 3))
        assert env.cycle.metadata["seed"] < TRAINING_SEED_LIMIT
    assert seen == {"bus_congested", "bus_launch"} and len(payloads) == 8
    lo, hi = get_scenario("random_service").payload_kg_range
    assert all(lo <= p <= hi for p in payloads)


def test_table_cache_follows_the_payload_of_a_fixed_cycle():
    """The demanded wheel power the observation shows depends on the mass: a heavier episode sees more."""
    env = HevThermalEnv(cycle="validation_bus:1", scenario="paper")
    start = int(np.flatnonzero(np.diff(load_cycle("validation_bus:1").speed_mps) > 0.3)[0])  # accelerating
    obs_light, _ = env.reset(seed=0, options={"start_s": start})
    env.sampler.conditions = get_scenario("full_bus").conditions
    obs_full, _ = env.reset(seed=0, options={"start_s": start})
    assert env.conditions.payload_kg == 4500.0
    demand = 2  # observation index of the demanded wheel power
    assert obs_light[demand] != 0.0 and abs(obs_full[demand]) > abs(obs_light[demand])
