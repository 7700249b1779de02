"""What gets installed: the strategies as ``hev_thermal_env.agents`` (no top-level ``agents`` module, mapped by
the packaging metadata alone), their data files, the console scripts, and an import of the package that leaves
torch alone."""

from __future__ import annotations

import inspect
import shutil
import subprocess
import sys
import zipfile
from importlib import import_module
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_console_scripts_return_an_exit_status():
    scripts = PYPROJECT["project"]["scripts"]
    assert scripts == {"hev-evaluate": "hev_thermal_env.cli.evaluate:main",
                       "hev-train": "hev_thermal_env.cli.train:main"}
    for target in scripts.values():
        module, _, name = target.partition(":")
        main = getattr(import_module(module), name)
        assert inspect.signature(main).return_annotation in (int, "int")


def test_every_package_is_listed_and_agents_is_mapped():
    setuptools = PYPROJECT["tool"]["setuptools"]
    found = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "hev_thermal_env").rglob("__init__.py")}
    assert set(setuptools["packages"]) == found | {"hev_thermal_env.agents"}
    assert setuptools["package-dir"]["hev_thermal_env.agents"] == "agents"
    assert not any(p == "agents" or p.startswith("agents.") for p in setuptools["packages"])


def test_the_package_adds_no_import_machinery():
    """``hev_thermal_env.agents`` comes from ``package-dir`` alone: importing the package adds no finder."""
    code = ("import sys; before = list(sys.meta_path); import hev_thermal_env, hev_thermal_env.agents as a; "
            "print(len(sys.meta_path) - len(before), a.__file__)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    added, agents_init = r.stdout.split()
    assert added == "0" and Path(agents_init).parent.name == "agents"
    assert not (ROOT / "hev_thermal_env" / "_checkout.py").exists()


def test_importing_the_package_leaves_torch_alone():
    modules = "hev_thermal_env, hev_thermal_env.agents, hev_thermal_env.evaluation, hev_thermal_env.cli.evaluate"
    code = f"import sys, {modules}; print(sorted(m for m in ('torch', 'stable_baselines3') if m in sys.modules))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


def test_the_wheel_installs_agents_under_hev_thermal_env_only(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for name in ("hev_thermal_env", "agents"):
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                        str(tmp_path / "dist"), str(src)], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        pytest.skip(f"cannot build a wheel here: {r.stderr.strip().splitlines()[-1:]}")
    (wheel,) = (tmp_path / "dist").glob("hev_thermal_env-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert tops == {"hev_thermal_env", next(t for t in tops if t.endswith(".dist-info"))}
    for required in ("agents/__init__.py", "agents/ppo.py", "agents/hyperparams/ppo.yaml",
                     "agents/policies/ppo_default/model.zip", "training/loop.py", "cli/evaluate.py", "io.py"):
        required = f"hev_thermal_env/{required}"
        assert required in names, required
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "hev-evaluate = hev_thermal_env.cli.evaluate:main" in text
    assert "hev-train = hev_thermal_env.cli.train:main" in text


def test_licence_files_match_the_metadata():
    assert PYPROJECT["project"]["license"] == {"text": "MIT"}
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    vendored = ROOT / "tests" / "data" / "advisor"
    assert (vendored / "ADVISOR-LICENSE.txt").is_file() and list(vendored.glob("*.json"))
