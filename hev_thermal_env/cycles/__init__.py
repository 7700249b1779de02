"""Drive cycles for the hybrid city-bus environment.

A :class:`Cycle` is a speed trace [m/s] and road grade (rise/run) sampled every second from
0 s, with read-only arrays and summary properties (distance, mean speed, idle fraction, ...).

* :func:`list_cycles` / :func:`load_cycle`: built-in cycles ``hwfet``, ``udds``, ``us06``,
  ``wltc_3b`` (standard cycles vendored from the ``fastsim==2.1.5`` wheel, Apache-2.0) and
  ``beijing`` (a *synthetic* city-bus cycle, generated, not measured), or any user CSV with
  columns ``time_s,speed_mps[,grade]``.
* :func:`cycle_from_arrays`: a validated cycle from arrays.
* :func:`generate_bus_cycle`: seeded synthetic stop-to-stop city-bus cycles.
* :class:`ImplausibleCycleWarning`: user data beyond a bus's range (speed above
  :data:`PLAUSIBLE_SPEED_MAX_MPS`, acceleration beyond :data:`PLAUSIBLE_ACCEL_MAX_MPS2`).
* :func:`generate_grade_profile`, :func:`with_grade_profile`, :func:`hilly_route`: seeded hilly
  roads under any cycle; ``hilly_route()`` is ``beijing`` over rolling hills (synthetic).
* :func:`generate_family_cycle`, :func:`list_families`: named, seeded families of generated bus cycles
  (long routes, congestion, hard launches, hills, mixed service), loadable as ``FAMILY:SEED``;
  ``validation_bus`` is a fixed set of them that training never draws (:func:`expand_cycle_names`).

Examples
--------
>>> from hev_thermal_env.cycles import load_cycle
>>> cyc = load_cycle("udds")
>>> round(cyc.distance_km, 2)
11.99
"""

from .cycle import PLAUSIBLE_ACCEL_MAX_MPS2, PLAUSIBLE_SPEED_MAX_MPS, Cycle, ImplausibleCycleWarning
from .families import cycle_statistics, generate_family_cycle, list_families
from .generator import generate_bus_cycle
from .grades import generate_grade_profile, hilly_route, with_grade_profile
from .loader import cycle_from_arrays, list_cycles, load_cycle
from .names import expand_cycle_names
from .validation import VALIDATION_SET

__all__ = ["PLAUSIBLE_ACCEL_MAX_MPS2", "PLAUSIBLE_SPEED_MAX_MPS", "VALIDATION_SET", "Cycle", "ImplausibleCycleWarning",
           "cycle_from_arrays", "cycle_statistics", "expand_cycle_names", "generate_bus_cycle", "generate_family_cycle",
           "generate_grade_profile", "hilly_route", "list_cycles", "list_families", "load_cycle", "with_grade_profile"]
