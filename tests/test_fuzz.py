"""Random-action fuzzing of the environment with a bounded budget (the long run: benchmarks/fuzz.py)."""

from tools.fuzz import fuzz


def test_fuzz_invariants_bounded_budget():
    report = fuzz(120_000, num_envs=64, seed=1)  # shared by the seven scenarios
    assert report["steps"] >= 120_000
    assert report["episodes"] > 0
    assert report["max_balance_error"] < 0.005
    # the hot and random scenarios heat the motor into the heat index's range and near the 70 °C protection
    assert report["derated_steps"] > 0 and report["temp_max_c"] > 60.0
