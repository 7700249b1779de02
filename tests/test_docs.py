"""The documentation site builds strictly (every link, cross-reference and docstring resolves)."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def load_extension():
    spec = importlib.util.spec_from_file_location("griffe_project", DOCS / "_ext" / "griffe_project.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> tuple[Path, str]:
    """The site built with ``mkdocs build --strict`` (the notebook is run by its own test, not here)."""
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, HEV_DOCS_EXECUTE_NOTEBOOK="false", NO_MKDOCS_2_WARNING="1")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                        "-d", str(out)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-5000:]
    return out, r.stdout + r.stderr


def test_site_builds_strict_with_every_page(site):
    out, log = site
    assert "not included in the \"nav\"" not in log, log
    pages = [p.relative_to(DOCS).with_suffix("") for p in DOCS.rglob("*.md")] + [Path("tutorial")]
    for page in pages:
        html = out / ("index.html" if page.name == "index" and page.parent == Path(".") else
                      page.parent / "index.html" if page.name == "index" else page / "index.html")
        assert html.is_file(), f"{page}: no {html.relative_to(out)}"
    for png in DOCS.glob("*.png"):
        assert (out / png.name).is_file(), png.name


def test_env_spec_page_renders_the_class_docstring(site):
    out, _ = site
    html = (out / "environment" / "index.html").read_text(encoding="utf-8")
    for heading in ("Action Space", "Observation Space", "Rewards", "Starting State", "Episode End", "Arguments"):
        assert heading in html, heading
    assert 'id="hev_thermal_env.envs.hev_env.HevThermalEnv"' in html


def test_api_reference_covers_every_room(site):
    out, _ = site
    for page, anchor in (("physics", "hev_thermal_env.physics.core.PhysicsCore"),
                         ("cycles", "hev_thermal_env.cycles.loader.load_cycle"),
                         ("envs", "hev_thermal_env.envs.reward.RewardParams"),
                         ("wrappers", "hev_thermal_env.wrappers.sb3.Sb3VecEnv"),
                         ("agents", "hev_thermal_env.agents.get_strategy"),
                         ("agents", "hev_thermal_env.agents.dp.DPStrategy"),
                         ("evaluation", "hev_thermal_env.evaluation.runner.run_strategy"),
                         ("training", "hev_thermal_env.training.loop.train"),
                         ("package", "hev_thermal_env.prices.Prices")):
        html = (out / "api" / page / "index.html").read_text(encoding="utf-8")
        assert f'id="{anchor}"' in html, (page, anchor)


def test_sphinx_roles_become_links_or_code(site):
    out, _ = site
    html = (out / "api" / "envs" / "index.html").read_text(encoding="utf-8")
    assert ":mod:" not in html and ":class:" not in html and ":func:" not in html
    assert 'href="../package/#hev_thermal_env.prices.Prices"' in html


def test_extension_fences_doctests_and_keeps_examples_sections():
    ext = load_extension()
    text = "Use it::\n\n>>> f()\n['a']\n\nExamples\n--------\n>>> g()\n1"
    assert ext.fence_doctests(text) == "Use it:\n\n```pycon\n>>> f()\n['a']\n```\n\nExamples\n--------\n>>> g()\n1"


def test_docs_extra_is_part_of_dev():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert set(extras["docs"]) <= set(extras["dev"]), set(extras["docs"]) - set(extras["dev"])
