"""The compile decorator of every numba kernel in the project, with a cache that cannot go stale, and their threads.

``error_model="numpy"``: division by zero gives inf/NaN instead of raising, which removes a branch from every
division in the hot loop; valid configurations never divide by zero and the fuzz tests check that no NaN or inf
reaches an output. ``nogil``: :func:`thread_pool` runs large batches on several threads.

Speed rule for the step (``core.step_kernel``): numba reference-counts array values with atomic calls and removes a
pair only when both sit on simple paths; in the per-row code these calls cost most of the time (≈270 ns, a row
≈50-90 ns). So: no per-row array views or per-row calls that bind arrays (index the 2-D arrays with the row), and a
component function taking a packed vector reads it for the last time outside any branch and returns from one place
(``thermal.cutoff_step``, ``thermal.available_torque_nm``, ``driveline.select_gear``).

**The cache** (docs/architecture.md, *The compiled cache*): :data:`CACHE_DIR`, named by :func:`source_hash` (a kernel
inlines other files' kernels and constants, so the hash covers them).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import os
import re
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from importlib.util import resolve_name
from pathlib import Path

import numba
from numba import njit
from numba.core import config as _numba_config

PACKAGE_DIR = Path(__file__).resolve().parent.parent
_OPTIONS = {"error_model": "numpy", "nogil": True}
_KERNEL_LINE = re.compile(rb"^@jit\b", re.M)
#: Batches smaller than this are not split over threads (thread start-up would dominate).
MIN_THREAD_BATCH = 4096


@functools.cache
def thread_pool(n: int) -> ThreadPoolExecutor:
    """The process's pool of ``n`` kernel threads."""
    return ThreadPoolExecutor(max_workers=n, thread_name_prefix="hev-kernel")


def package_modules() -> dict[str, Path]:
    """Every module of the package (dotted name -> source file)."""
    modules = {}
    for path in PACKAGE_DIR.rglob("*.py"):
        parts = [PACKAGE_DIR.name, *path.relative_to(PACKAGE_DIR).with_suffix("").parts]
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports at module level."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.parse(path.read_bytes()).body:
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            mod = node.module if not node.level else resolve_name("." * node.level + (node.module or ""), package)
            found.update(f"{mod}.{alias.name}" if f"{mod}.{alias.name}" in modules else mod for alias in node.names)
    return {f for f in found if f in modules and f != name}


def kernel_modules(modules: dict[str, Path] | None = None) -> list[str]:
    """The package's modules that define a kernel with :func:`jit` (an ``@jit`` line)."""
    modules = package_modules() if modules is None else modules
    return sorted(n for n, p in modules.items() if _KERNEL_LINE.search(p.read_bytes()))


def source_hash(roots: Iterable[str] | None = None) -> str:
    """Hash of the numba version and of the sources of ``roots`` (default: the kernel modules,
    :func:`kernel_modules`) and of every package module they import at module level, transitively."""
    modules = package_modules()
    seen: set[str] = set()
    todo = list(kernel_modules(modules) if roots is None else roots)
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo.extend(_imports(name, modules[name], modules) - seen)
    h = hashlib.sha256(numba.__version__.encode())
    for path in sorted(modules[n] for n in seen):
        h.update(path.relative_to(PACKAGE_DIR).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _usable_cache_dir() -> Path | None:
    """The cache directory of this source tree under the root that holds one per kernel source hash
    (``$HEV_THERMAL_ENV_CACHE_DIR``, else ``hev-thermal-env/numba`` in ``$XDG_CACHE_HOME`` or ``~/.cache``), or None
    where it cannot be written."""
    root = os.environ.get("HEV_THERMAL_ENV_CACHE_DIR")
    if not root:
        root = Path(os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")) / "hev-thermal-env" / "numba"
    path = Path(root) / source_hash()
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
_KERNEL_FILES = {package_modules()[n].resolve() for n in kernel_modules()}


def jit(fn):
    """``numba.njit`` with the project's options, cached in :data:`CACHE_DIR`; ``fn`` must be defined in a source
    file of the package with an ``@jit`` line (one that :func:`source_hash` covers)."""
    if Path(fn.__code__.co_filename).resolve() not in _KERNEL_FILES:
        raise RuntimeError(f"{fn.__module__}.{fn.__qualname__}: a kernel is compiled with @jit in a source file of "
                           f"{PACKAGE_DIR}, which the compiled cache's key covers")
    if CACHE_DIR is None:
        return njit(cache=False, **_OPTIONS)(fn)
    previous = _numba_config.CACHE_DIR  # process-wide: set only while the dispatcher picks its cache locator
    _numba_config.CACHE_DIR = str(CACHE_DIR)
    try:
        return njit(cache=True, **_OPTIONS)(fn)
    finally:
        _numba_config.CACHE_DIR = previous
