"""The documented envelope of the cycle families (docs/cycle-families.md): the bounds every generated cycle's
statistics keep, the oracle of ``tests/test_cycle_families.py`` and ``benchmarks/cycle_families.py``."""

from __future__ import annotations

#: The documented envelope of each family's :func:`~hev_thermal_env.cycles.cycle_statistics` (low, high), for every
#: seed: exact for durations, top speeds, accelerations and grades (limits of the draws), measured with a margin for
#: the rest (``benchmarks/cycle_families.py`` gives the ranges over 300 seeds). Payload: 0-4,500 kg for every
#: family, from the training scenario (``random_service``), not from the cycle.
FAMILY_BOUNDS: dict[str, dict[str, tuple[float, float]]] = {
    "random_bus": {"duration_s": (1300, 1300), "mean_speed_kmh": (10, 25), "max_speed_kmh": (30, 60),
                   "stops_per_km": (1.5, 6.5), "idle_fraction": (0.15, 0.40), "max_accel_mps2": (0.9, 1.0),
                   "max_decel_mps2": (0.85, 1.0), "grade_min": (0, 0), "grade_max": (0, 0)},
    "bus_long": {"duration_s": (3000, 4200), "mean_speed_kmh": (12, 28), "max_speed_kmh": (40, 70),
                 "stops_per_km": (1.2, 5.0), "idle_fraction": (0.15, 0.35), "max_accel_mps2": (0.9, 1.0),
                 "max_decel_mps2": (0.85, 1.0), "grade_min": (0, 0), "grade_max": (0, 0)},
    "bus_congested": {"duration_s": (1200, 2400), "mean_speed_kmh": (5, 9), "max_speed_kmh": (20, 35),
                      "stops_per_km": (9, 20), "idle_fraction": (0.30, 0.50), "max_accel_mps2": (0.7, 0.8),
                      "max_decel_mps2": (0.8, 0.9), "grade_min": (0, 0), "grade_max": (0, 0)},
    "bus_launch": {"duration_s": (1200, 2000), "mean_speed_kmh": (10, 19), "max_speed_kmh": (30, 60),
                   "stops_per_km": (3, 9), "idle_fraction": (0.25, 0.50), "max_accel_mps2": (1.3, 2.2),
                   "max_decel_mps2": (1.6, 2.0), "grade_min": (0, 0), "grade_max": (0, 0)},
    "bus_hilly": {"duration_s": (1200, 2400), "mean_speed_kmh": (10, 25), "max_speed_kmh": (30, 60),
                  "stops_per_km": (1.5, 6.5), "idle_fraction": (0.15, 0.40), "max_accel_mps2": (0.9, 1.0),
                  "max_decel_mps2": (0.85, 1.0), "grade_min": (-0.08, -0.01), "grade_max": (0.01, 0.08)},
    "bus_mixed": {"duration_s": (3000, 4500), "mean_speed_kmh": (5, 36), "max_speed_kmh": (25, 70),
                  "stops_per_km": (0.5, 18), "idle_fraction": (0.10, 0.50), "max_accel_mps2": (0.75, 2.2),
                  "max_decel_mps2": (0.8, 2.0), "grade_min": (-0.07, 0), "grade_max": (0, 0.07)},
    "bus_express": {"duration_s": (1800, 3600), "mean_speed_kmh": (35, 75), "max_speed_kmh": (80, 115),
                    "stops_per_km": (0.2, 1.2), "idle_fraction": (0.05, 0.30), "max_accel_mps2": (1.3, 1.5),
                    "max_decel_mps2": (0.8, 1.5), "grade_min": (-0.05, 0), "grade_max": (0, 0.05)},
}
