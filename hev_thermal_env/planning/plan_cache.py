"""Solved thermal-optimum plans kept on disk (JSON in ``plans/`` beside the compiled-kernel cache), reused by a
run of the same problem.

A plan's file name hashes its key (cycle, start, vehicle, reward, settings:
:meth:`~.thermal_optimum.OptimumSettings.key`) and the sources the planner runs (:mod:`.thermal_optimum` and every
module it imports: :func:`~hev_thermal_env.physics.jit.source_hash`), so an edit of any of them solves afresh and an
edit elsewhere does not. Without a writable cache directory nothing is kept.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.physics.jit import CACHE_DIR, source_hash

from . import thermal_optimum
from .problem import DPProblem
from .thermal_optimum import OptimumPlan, OptimumSettings, in_worker_process, plan_optimum

_told = False


def cached_plan(problem: DPProblem, settings: OptimumSettings, use_cache: bool = True) -> OptimumPlan:
    """The plan of ``problem``: read from disk if it was solved before (its report then says ``from_cache``), else
    solved by :func:`~.thermal_optimum.plan_optimum` and kept (``use_cache=False``: always solved, not kept)."""
    grid = settings.grid_for(problem.n_stages)
    path = None
    if use_cache and CACHE_DIR is not None:
        key = settings.key(problem) + source_hash([thermal_optimum.__name__])
        path = CACHE_DIR.parent / "plans" / f"dp_thermal-{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"
    if path is not None and path.is_file():
        try:
            data = json.loads(path.read_text())
            return OptimumPlan(u=np.asarray(data["u"], dtype=np.float64), report=dict(data["report"], from_cache=True),
                               grid=grid)
        except (OSError, ValueError, KeyError):
            pass
    plan = plan_optimum(problem, settings)
    if path is not None:
        try:
            atomic_write_json(path, {"u": plan.u.tolist(), "report": plan.report})
        except OSError:
            return plan
        _tell(path)
    return plan


def _tell(path: Path) -> None:
    """Say once per process (not in pool workers) where plans are kept."""
    global _told
    if not _told and not in_worker_process():
        _told = True
        tqdm.write(f"dp_thermal: plan kept in {path.parent}/ and reused whenever the same cycle, start, vehicle and "
                   f"settings come again (plan_cache=False solves afresh)", file=sys.stderr)
