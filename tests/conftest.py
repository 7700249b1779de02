"""The suite's two tiers, its rule on skips, and shared fixtures.

``python -m pytest`` runs the fast tier, what a developer runs after every change: the physics, the
envs, every strategy on short cycles, the command line on tiny inputs and bad inputs, in a few
minutes. ``python -m pytest --full`` runs the full suite (what ``.ci/run`` runs): the fast tier and
the tests marked ``full``, those of the modules in :data:`FULL_MODULES` and single slow tests marked
``@pytest.mark.full``. The fast tier deselects them (the summary line counts them as
"deselected"); a test file named on the command line runs whole in either tier.

Both tiers run on two worker processes (pytest-xdist, ``-n 2 --dist loadgroup`` in ``pyproject.toml``; ``-n 0``
runs in one process). A test module with a fixture it shares across its tests (``scope="module"`` or wider) runs
whole on one worker, so the fixture is built once; other tests are dealt out one by one. Tests that must not run at
the same time as others share an ``xdist_group`` mark (Ray's runtimes: ``"ray"``). The ``full`` tests, the long
ones, are dealt out first, then the larger groups, so that no worker is left with a long one at the end.
"""

import os
from pathlib import Path
from types import SimpleNamespace

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
_DESELECTED_IDS = pytest.StashKey[list[str]]()
_WIDE_SCOPES = ("module", "package", "session")

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


def _shares_a_module_fixture(item) -> bool:
    """Whether ``item`` uses a fixture of module scope or wider defined in its own test module."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return False
    module = item.nodeid.split("::")[0]
    return any(d.scope in _WIDE_SCOPES and d.baseid == module
               for name in item.fixturenames for d in info.name2fixturedefs.get(name, ()))


def _group_for_the_workers(items) -> None:
    """Under pytest-xdist (a worker collects): a module sharing a fixture is one group, and the groups are ordered
    as the scheduler deals them out (``--no-loadscope-reorder``): those with full tests first, then the larger ones."""
    groups: dict[str, list] = {}
    for item in items:
        if item.get_closest_marker("xdist_group") is None and _shares_a_module_fixture(item):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
        mark = item.get_closest_marker("xdist_group")
        groups.setdefault(item.nodeid if mark is None else f"@{mark.args[0]}", []).append(item)
    ordered = sorted(groups.values(), key=lambda g: (all(i.get_closest_marker("full") is None for i in g), -len(g)))
    items[:] = [item for group in ordered for item in group]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in FULL_MODULES:
            item.add_marker(pytest.mark.full)
    if not config.getoption("full"):
        named = _named_files(config)
        fast = [item for item in items if item.get_closest_marker("full") is None or item.path in named]
        deselected = [item for item in items if item not in fast]
        config.stash[_DESELECTED] = len(deselected)
        config.stash[_DESELECTED_IDS] = [item.nodeid for item in deselected]
        if deselected:
            config.hook.pytest_deselected(items=deselected)
            items[:] = fast
    if hasattr(config, "workerinput"):  # a pytest-xdist worker
        config.workeroutput["deselected"] = config.stash.get(_DESELECTED_IDS, [])
        _group_for_the_workers(items)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """The controller (pytest-xdist): the summary line counts the tests the fast tier deselected, once."""
    config = node.config
    nodeids = getattr(node, "workeroutput", {}).get("deselected")
    if nodeids and _DESELECTED not in config.stash:
        config.stash[_DESELECTED] = len(nodeids)
        config.hook.pytest_deselected(items=[SimpleNamespace(nodeid=nodeid) for nodeid in nodeids])


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
