"""Drive cycles: a :class:`Cycle` is a speed trace [m/s] and road grade (rise/run) sampled every second from 0 s.

* :func:`load_cycle`, :func:`list_cycles`, :func:`cycle_from_arrays`: built-in cycles, user CSV files
  (``time_s,speed_mps[,grade]``), generated cycles by name and arrays (:mod:`.loader`); user data beyond a bus's
  range gives an :class:`ImplausibleCycleWarning`.
* :func:`generate_bus_cycle`: seeded synthetic stop-to-stop city-bus cycles (:mod:`.generator`);
  :func:`generate_grade_profile`, :func:`with_grade_profile`: seeded hilly roads
  (:mod:`.generator`).
* :func:`generate_family_cycle`, :func:`list_families`: families of generated bus cycles, loadable as
  ``FAMILY:SEED`` (:mod:`.families`); ``validation_bus``, a fixed set of them that training never draws
  (:mod:`.names`, :func:`expand_cycle_names`).
"""

from .cycle import PLAUSIBLE_ACCEL_MAX_MPS2, PLAUSIBLE_SPEED_MAX_MPS, Cycle, ImplausibleCycleWarning
from .families import cycle_statistics, generate_family_cycle, list_families
from .generator import generate_bus_cycle, generate_grade_profile, with_grade_profile
from .loader import cycle_from_arrays, list_cycles, load_cycle
from .names import VALIDATION_SET, expand_cycle_names

__all__ = ["PLAUSIBLE_ACCEL_MAX_MPS2", "PLAUSIBLE_SPEED_MAX_MPS", "VALIDATION_SET", "Cycle", "ImplausibleCycleWarning",
           "cycle_from_arrays", "cycle_statistics", "expand_cycle_names", "generate_bus_cycle", "generate_family_cycle",
           "generate_grade_profile", "list_cycles", "list_families", "load_cycle", "with_grade_profile"]
