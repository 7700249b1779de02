import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "advisor"
"""ADVISOR maps the tests compare against, vendored with their licence (``ADVISOR-LICENSE.txt``)."""

os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_addoption(parser):
    parser.addoption("--allow-skips", action="store_true", default=False,
                     help="report skipped tests as skips; by default a skip is a failure (a fresh clone skips nothing)")


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
            reporter.write_line(f"SKIPPED (a skip is a failure here; --allow-skips to permit): {rep.nodeid} "
                                f"{rep.longrepr}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    return REFERENCE
