"""The compiled-kernel cache cannot serve old physics after a physics source changes."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import hev_thermal_env

PACKAGE = Path(hev_thermal_env.__file__).resolve().parent

PROBE = """
import numpy as np
from hev_thermal_env.physics import Conditions, PhysicsCore, paper_bus
from hev_thermal_env.physics.jit import CACHE_DIR
core = PhysicsCore(paper_bus())
st = core.initial_state(Conditions(initial_motor_temp_c=50.0), 1)
state, out = core.step(st, np.array([0.8]), np.array([10.0]), np.array([11.0]), np.array([0.0]),
                       core.conditions_array(Conditions(), 1))
print(repr(float(state[0, 1])), CACHE_DIR)
"""


def _run(root: Path, cache: Path) -> tuple[str, str]:
    env = dict(os.environ, PYTHONPATH=str(root), HEV_THERMAL_ENV_CACHE_DIR=str(cache))
    res = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, cwd=root,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    temp, cache_dir = res.stdout.split()
    return temp, cache_dir


@pytest.mark.full
def test_edit_of_an_inlined_component_is_compiled_not_served_from_cache(tmp_path):
    root = tmp_path / "src"
    shutil.copytree(PACKAGE, root / "hev_thermal_env", ignore=shutil.ignore_patterns("__pycache__", "data"))
    shutil.copytree(PACKAGE / "cycles" / "data", root / "hev_thermal_env" / "cycles" / "data")
    cache = tmp_path / "cache"
    temp1, dir1 = _run(root, cache)
    temp2, dir2 = _run(root, cache)  # unchanged tree: same cache directory, same result
    assert (temp2, dir2) == (temp1, dir1)
    assert any(Path(dir1).rglob("*.nbi")), "nothing was cached"
    # thermal.py is inlined into core.step_kernel, whose own file does not change
    thermal = root / "hev_thermal_env" / "physics" / "thermal.py"
    text = thermal.read_text()
    assert "SIGMA = 5.67e-8" in text
    thermal.write_text(text.replace("SIGMA = 5.67e-8", "SIGMA = 5.67e-8 * 1e4"))
    temp3, dir3 = _run(root, cache)
    assert dir3 != dir1
    assert float(temp3) != float(temp1), "the edited radiation constant did not reach the compiled step"


def test_the_keys_follow_the_sources_that_kernels_and_planners_read(tmp_path, monkeypatch):
    """The compiled cache's key covers the files with kernels and what they import (found, not listed); a plan's
    key covers what the planner runs: an edit of the observation alone re-solves no plan."""
    from hev_thermal_env.physics import jit

    copy = tmp_path / "hev_thermal_env"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "data", "agents"))
    monkeypatch.setattr(jit, "PACKAGE_DIR", copy)
    kernels = set(jit.kernel_modules())
    assert {"hev_thermal_env.physics.core", "hev_thermal_env.envs.reward", "hev_thermal_env.envs.batch",
            "hev_thermal_env.planning.stage"} <= kernels
    assert "hev_thermal_env.physics.config" not in kernels and "hev_thermal_env.planning.search" not in kernels
    plans = ["hev_thermal_env.planning.thermal_optimum"]
    base = jit.source_hash(), jit.source_hash(plans)

    def edited(rel: str) -> tuple[bool, bool]:
        """Whether an edit of ``rel`` changes the kernels' key and the plans' key."""
        path = copy / rel
        text = path.read_text()
        path.write_text(text + "\n# edited\n")
        try:
            return jit.source_hash() != base[0], jit.source_hash(plans) != base[1]
        finally:
            path.write_text(text)

    assert edited("physics/thermal.py") == (True, True)
    assert edited("physics/config.py") == (True, True)  # no kernel, but the kernels read its values
    assert edited("envs/reward.py") == (True, True)  # inlined into the env's fused step and priced by the planners
    assert edited("envs/batch.py") == (True, False)
    assert edited("envs/spaces.py") == (True, False)  # the observation kernel reads its layout
    assert edited("planning/thermal_optimum.py") == (False, True)
    assert edited("envs/render.py") == (False, False)


def test_a_kernel_outside_the_package_is_refused():
    from hev_thermal_env.physics.jit import jit

    def double(x):
        return 2.0 * x

    with pytest.raises(RuntimeError, match="compiled cache's key"):
        jit(double)
