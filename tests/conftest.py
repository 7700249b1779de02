import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "advisor"
"""ADVISOR maps the tests compare against, vendored with their licence (``ADVISOR-LICENSE.txt``)."""

os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_addoption(parser):
    parser.addoption("--fail-on-skip", action="store_true", default=False,
                     help="report every skipped test as a failure (CI: a fresh clone must skip nothing)")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    if rep.skipped and not hasattr(rep, "wasxfail") and item.config.getoption("fail_on_skip"):
        reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
        rep.outcome = "failed"
        rep.longrepr = f"skipped, and --fail-on-skip forbids skips: {reason}"


def pytest_sessionfinish(session, exitstatus):
    """With --fail-on-skip, whole modules skipped at collection (``importorskip``) fail the run too."""
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter is not None else []
    if skipped and session.config.getoption("fail_on_skip"):
        for rep in skipped:
            reporter.write_line(f"SKIPPED, and --fail-on-skip forbids skips: {rep.nodeid} {rep.longrepr}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    return REFERENCE
