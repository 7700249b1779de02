"""The suite's two tiers, its rule on skips, and shared fixtures.

``python -m pytest`` runs the fast tier, what a developer runs after every change: the physics, the
envs, every strategy on short cycles, the command line on tiny inputs and bad inputs, in a few
minutes. ``python -m pytest --full`` runs the full suite (what ``.ci/run`` runs): the fast tier and
the tests marked ``full``, those of the modules in :data:`FULL_MODULES` and single slow tests marked
``@pytest.mark.full``. The fast tier deselects them (the summary line counts them as
"deselected"); a test file named on the command line runs whole in either tier.
"""

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "advisor"
"""ADVISOR maps the tests compare against, vendored with their licence (``ADVISOR-LICENSE.txt``)."""

#: Test modules of the full tier only, with why: each runs for minutes, not seconds.
FULL_MODULES = {
    "test_readme.py": "replays every command and snippet of the README and the docs: the main job, training, Ray",
    "test_docs.py": "builds the documentation site",
    "test_tutorial.py": "runs the tutorial notebook (it trains a tiny PPO)",
}

_DESELECTED = pytest.StashKey[int]()

os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_addoption(parser):
    parser.addoption(
        "--full",
        action="store_true",
        default=False,
        help="run the full suite (by default the fast tier: tests marked 'full' are deselected)",
    )
    parser.addoption(
        "--allow-skips",
        action="store_true",
        default=False,
        help="report skipped tests as skips; by default a skip is a failure (a fresh clone skips nothing)",
    )


def _named_files(config) -> set[Path]:
    """Test files named on the command line, alone or with a test (``FILE.py``, ``FILE.py::TEST``)."""
    here = Path(config.invocation_params.dir)
    return {(here / arg.split("::")[0]).resolve() for arg in config.args if arg.split("::")[0].endswith(".py")}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in FULL_MODULES:
            item.add_marker(pytest.mark.full)
    if config.getoption("full"):
        return
    named = _named_files(config)
    fast = [item for item in items if item.get_closest_marker("full") is None or item.path in named]
    deselected = [item for item in items if item not in fast]
    config.stash[_DESELECTED] = len(deselected)
    if deselected:
        config.hook.pytest_deselected(items=deselected)
        items[:] = fast


def pytest_report_collectionfinish(config, start_path, items):
    if config.getoption("full"):
        return "full suite"
    return f"fast tier: {config.stash.get(_DESELECTED, 0)} tests of the full suite deselected (--full runs them)"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if rep.skipped and not hasattr(rep, "wasxfail") and not item.config.getoption("allow_skips"):
        reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
        rep.outcome = "failed"
        rep.longrepr = f"skipped (a skip is a failure here; --allow-skips to permit): {reason}"


def pytest_sessionfinish(session, exitstatus):
    """Whole modules skipped at collection (``importorskip``) fail the run too, unless --allow-skips."""
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter is not None else []
    if skipped and not session.config.getoption("allow_skips"):
        for rep in skipped:
            reporter.write_line(
                f"SKIPPED (a skip is a failure here; --allow-skips to permit): {rep.nodeid} {rep.longrepr}", red=True
            )
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    return REFERENCE
