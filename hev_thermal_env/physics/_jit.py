"""The compile decorator shared by every physics kernel.

``error_model="numpy"``: division by zero gives inf/NaN instead of raising, which removes a
branch from every division in the hot loop; the kernels never divide by a quantity that can be
zero in a valid configuration (the configs validate their ranges), and the fuzz tests check that
no NaN or inf reaches an output.

Speed rule for the step (``core.step_kernel``): numba reference-counts array values with atomic
calls (``NRT_incref``/``NRT_decref``) and removes a pair only when both sit on simple paths. In the
per-row code these calls were most of the time, so: no per-row array views or per-row calls that
bind arrays (index the 2-D arrays with the row instead), and in a component function taking a
packed vector, read the vector for the last time outside any branch and return from one place
(``thermal.cutoff_step``, ``thermal.heat_flows_w``, ``driveline.select_gear``).

``cache=True`` keys each cache on its own file only: after editing a component module, a cached
``step_kernel`` that inlined the old code is still loaded until ``core.py`` changes (or the
``__pycache__`` entries of ``core`` are deleted).
"""

from numba import njit

jit = njit(cache=True, error_model="numpy", nogil=True)
