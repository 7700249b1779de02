"""The compile decorator shared by every physics kernel.

``error_model="numpy"``: division by zero gives inf/NaN instead of raising, which removes a
branch from every division in the hot loop; the kernels never divide by a quantity that can be
zero in a valid configuration (the configs validate their ranges), and the fuzz tests check that
no NaN or inf reaches an output.
"""

from numba import njit

jit = njit(cache=True, error_model="numpy")
