"""Shared test fixtures: where the shared datasets live, unique robot names per test."""

from __future__ import annotations

import fcntl
import os
import tempfile
import uuid
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# CI clones main with shared/ beside it; developers have it at ../shared too.
SHARED = Path(os.environ.get("ZENAV_SHARED", REPO.parent / "shared")).resolve()


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.exists():
        pytest.fail(f"shared data folder not found at {SHARED} (set ZENAV_SHARED)")
    return SHARED


@pytest.fixture
def robot_name() -> str:
    """A robot name unique to this test, so key expressions never cross-talk between runs."""
    return "t" + uuid.uuid4().hex[:10]


# Lines a test leaves in its report as ("summary:<section title>", text), printed after the run. Reports
# come back from xdist's workers, so this works whether or not the suite runs in parallel.
_SUMMARY: dict[str, list[str]] = {}


def pytest_runtest_logreport(report):
    if report.when == "teardown":
        for key, text in report.user_properties:
            if key.startswith("summary:"):
                _SUMMARY.setdefault(key.removeprefix("summary:"), []).append(text)


def pytest_terminal_summary(terminalreporter):
    for title, lines in _SUMMARY.items():
        terminalreporter.section(title)
        for line in lines:
            terminalreporter.write_line(line)


# The long end-to-end folders first (longest first, roughly, from `--durations=0`): with two workers
# taking whole modules, a long module left for the end would run alone while the other worker idles.
_LONG_FIRST = ("nav_e2e", "fleet", "sim_e2e", "logs", "monitor", "reliability", "slam_e2e", "barn", "bus",
               "amcl", "deploy", "demo", "costmap_e2e", "agent")


def pytest_collection_modifyitems(items):
    def rank(item) -> int:
        parts = item.nodeid.split("/")
        return _LONG_FIRST.index(parts[1]) if len(parts) > 2 and parts[1] in _LONG_FIRST else len(_LONG_FIRST)

    items.sort(key=rank)  # stable: the order inside each folder is kept


# A module marked `alone` (pytestmark = pytest.mark.alone) runs while no other module runs on the other
# xdist worker: its timing is the point (the link-fault tests' netem link and partitions). Every other
# module holds a shared lock for its whole run; an `alone` module first closes a gate (new modules wait
# there), then takes the lock exclusively once the running module is done. Without xdist: no locks.
@pytest.fixture(scope="module", autouse=True)
def _module_turn(request):
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")
    if not run:
        yield
        return
    base = Path(tempfile.gettempdir()) / f"zenav-tests-{run}"
    alone = request.node.get_closest_marker("alone") is not None
    with open(f"{base}.gate", "a") as gate, open(f"{base}.turn", "a") as turn:
        fcntl.flock(gate, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        fcntl.flock(turn, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        if not alone:
            fcntl.flock(gate, fcntl.LOCK_UN)  # the gate is only passed through
        try:
            yield
        finally:
            fcntl.flock(turn, fcntl.LOCK_UN)
            if alone:
                fcntl.flock(gate, fcntl.LOCK_UN)
