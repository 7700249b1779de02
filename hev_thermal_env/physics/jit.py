"""The compile decorator of every numba kernel in the project, with a cache that cannot go stale.

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

**The cache.** numba keys a cached function on the file that defines it, but a kernel inlines the
component functions of *other* files: after an edit of ``thermal.py`` a cached ``step_kernel``
would still run the old thermal code. So the compiled cache lives in a directory named after a
hash of every source file that defines kernels (the physics package, the env's reward and batch
engine, the planners' kernels; :data:`KERNEL_SOURCES`) and of the numba version: any edit of them
gives a new directory and a fresh compilation, and an unchanged tree reuses its cache (the env's
fused step inlines the reward, so an edit of ``reward.py`` alone must recompile it too). The directory is
``$HEV_THERMAL_ENV_CACHE_DIR/<hash>`` if that variable is set, else
``$XDG_CACHE_HOME/hev-thermal-env/numba/<hash>`` (``~/.cache/...``). If it cannot be created the
kernels are compiled without a cache (slower start, never stale). Every numba function of the
project, inside or outside the physics package, is compiled with :func:`jit` so that none of them
keeps compiled copies of physics constants from an older tree.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba
from numba import njit
from numba.core import config as _numba_config

PHYSICS_DIR = Path(__file__).resolve().parent
_PACKAGE_DIR = PHYSICS_DIR.parent
#: Source files outside the physics package that define or inline kernels (missing ones are skipped: the
#: strategies live in ``agents/`` of a checkout, installed as ``hev_thermal_env/agents``).
KERNEL_SOURCES = ("envs/reward.py", "envs/batch.py", "agents/dp_grid.py", "agents/optimum_search.py",
                  "agents/optimum_stage.py")

_OPTIONS = {"error_model": "numpy", "nogil": True}


def _agents_dir() -> Path:
    installed = _PACKAGE_DIR / "agents"
    return installed if installed.is_dir() else _PACKAGE_DIR.parent / "agents"


def source_hash(directory: Path = PHYSICS_DIR) -> str:
    """Hash of the kernel sources (file names and contents: ``directory``'s and :data:`KERNEL_SOURCES`) and of
    the numba version."""
    h = hashlib.sha256(numba.__version__.encode())
    paths = sorted(directory.glob("*.py"))
    for rel in KERNEL_SOURCES:
        path = (_agents_dir() / rel.split("/", 1)[1]) if rel.startswith("agents/") else _PACKAGE_DIR / rel
        if path.is_file():
            paths.append(path)
    for path in paths:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def cache_root() -> Path:
    """The directory that holds one cache directory per physics source hash."""
    explicit = os.environ.get("HEV_THERMAL_ENV_CACHE_DIR")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hev-thermal-env" / "numba"


def _usable_cache_dir() -> Path | None:
    path = cache_root() / source_hash()
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError:
        return None
    return path


CACHE_DIR = _usable_cache_dir()
"""Where the compiled kernels of this source tree are cached (None: no cache)."""


def jit(fn):
    """``numba.njit`` with the project's options, cached in :data:`CACHE_DIR`."""
    if CACHE_DIR is None:
        return njit(cache=False, **_OPTIONS)(fn)
    previous = _numba_config.CACHE_DIR
    _numba_config.CACHE_DIR = str(CACHE_DIR)  # read once, when the dispatcher picks its cache locator
    try:
        return njit(cache=True, **_OPTIONS)(fn)
    finally:
        _numba_config.CACHE_DIR = previous
