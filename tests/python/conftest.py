"""Skips that would hide a missing dependency are failures.

scripts/install-deps.sh installs every module and program these tests use (selenium and
chromium-driver, websocket, MDAnalysis, pydicom, tifffile, pyopenvdb, matplotlib), so under ctest
(PENUMBRA_STRICT_SKIPS=1) a test skipped for any other reason than missing staged data fails the run.
A skip for missing data says so with a reason that starts with MISSING_DATA (../shared/data is not part
of the repository). The summary lists every skip with its reason either way (ctest runs pytest -rs).
"""
import os

import pytest

MISSING_DATA = "missing data:"

_skips = []


def _record(report):
    if report.skipped:
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        _skips.append((report.nodeid, reason.removeprefix("Skipped: ")))


def pytest_collectreport(report):
    _record(report)


def pytest_runtest_logreport(report):
    _record(report)


def pytest_sessionfinish(session, exitstatus):
    if os.environ.get("PENUMBRA_STRICT_SKIPS") != "1":
        return
    hidden = [(node, reason) for node, reason in _skips if not reason.startswith(MISSING_DATA)]
    if hidden:
        lines = "\n".join(f"  {node}: {reason}" for node, reason in hidden)
        print(f"\n{len(hidden)} test(s) skipped for want of what scripts/install-deps.sh installs:\n{lines}")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
