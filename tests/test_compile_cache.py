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


@pytest.mark.slow
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


def test_the_cache_directory_follows_the_kernels_outside_the_physics_package(tmp_path):
    """The env's fused step inlines the reward: an edit of ``envs/reward.py`` alone names a new cache directory."""
    from hev_thermal_env.physics import jit

    root = tmp_path / "src"
    shutil.copytree(PACKAGE, root / "hev_thermal_env", ignore=shutil.ignore_patterns("__pycache__", "data"))
    copy = root / "hev_thermal_env"
    before = subprocess.run([sys.executable, "-c", "from hev_thermal_env.physics.jit import source_hash; "
                             "print(source_hash())"], capture_output=True, text=True, cwd=root,
                            env=dict(os.environ, PYTHONPATH=str(root))).stdout.strip()
    reward = copy / "envs" / "reward.py"
    reward.write_text(reward.read_text() + "\n# edited\n")
    after = subprocess.run([sys.executable, "-c", "from hev_thermal_env.physics.jit import source_hash; "
                            "print(source_hash())"], capture_output=True, text=True, cwd=root,
                           env=dict(os.environ, PYTHONPATH=str(root))).stdout.strip()
    assert before and after and before != after
    assert "envs/reward.py" in jit.KERNEL_SOURCES and "envs/batch.py" in jit.KERNEL_SOURCES
