"""Argument handling of the door to the kernel (:meth:`PhysicsCore.step`): dtype, shape and threads.

Every input reaches the kernel as a float64 C-contiguous array (one compiled specialisation, no silent
recompilation for float32 or strided input); bad shapes raise a one-line ``ValueError`` naming the argument.
"""

from __future__ import annotations

import functools
from concurrent.futures import ThreadPoolExecutor

import numpy as np

#: Batches smaller than this are not split over threads (thread start-up would dominate).
MIN_THREAD_BATCH = 4096


@functools.cache
def thread_pool(n: int) -> ThreadPoolExecutor:
    """The process's pool of ``n`` kernel threads."""
    return ThreadPoolExecutor(max_workers=n, thread_name_prefix="hev-kernel")


def as_float64(x, name: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"PhysicsCore.step: {name} must be numeric, got {type(x).__name__}") from None


def as_batch(x, b: int, name: str) -> np.ndarray:
    a = as_float64(x, name)
    if a.shape == (b,):
        return a
    if a.ndim == 0 or a.shape == (1,):
        return np.full(b, float(a.reshape(-1)[0]))
    raise ValueError(f"PhysicsCore.step: {name} must be a scalar or have shape ({b},), got {a.shape}")


def checked_out(x: np.ndarray, shape: tuple[int, int], name: str) -> np.ndarray:
    if not (isinstance(x, np.ndarray) and x.dtype == np.float64 and x.flags.c_contiguous and x.shape == shape):
        raise ValueError(f"PhysicsCore.step: {name} must be a C-contiguous float64 array of shape {shape}")
    return x
