"""Drive cycles: a :class:`Cycle` is a speed trace [m/s] and road grade (rise/run) sampled every second from 0 s.

Built-in cycles, user CSV files, generated cycles by name and arrays (:mod:`.loader`); seeded synthetic city-bus
cycles and hilly roads (:mod:`.generator`); families of generated bus cycles, loadable as ``FAMILY:SEED``
(:mod:`.families`); the names of generated cycles and sets such as the validation set ``validation_bus``
(:mod:`.names`).
"""

from .cycle import PLAUSIBLE_ACCEL_MAX_MPS2, PLAUSIBLE_SPEED_MAX_MPS, Cycle, ImplausibleCycleWarning
from .families import cycle_statistics, generate_family_cycle, list_families
from .generator import generate_bus_cycle, generate_grade_profile, with_grade_profile
from .loader import cycle_from_arrays, list_cycles, load_cycle
from .names import expand_cycle_names

__all__ = ["PLAUSIBLE_ACCEL_MAX_MPS2", "PLAUSIBLE_SPEED_MAX_MPS", "Cycle", "ImplausibleCycleWarning",
           "cycle_from_arrays", "cycle_statistics", "expand_cycle_names", "generate_bus_cycle",
           "generate_family_cycle", "generate_grade_profile", "list_cycles", "list_families", "load_cycle",
           "with_grade_profile"]
