"""Shared test fixtures: where the shared datasets live, unique robot names per test."""

from __future__ import annotations

import os
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


# The long end-to-end folders first (longest first, roughly, from `--durations=0`): with workers
# taking whole modules, a long module left for the end would run alone while the others idle.
# pyproject's --no-loadscope-reorder keeps this order: xdist's loadfile otherwise sorts modules by their
# number of tests, which left one-test end-to-end modules (web tools, fuzz, amcl) for the end.
_LONG_FIRST = ("nav_e2e", "fleet", "sim_e2e", "logs", "monitor", "reliability", "slam_e2e", "barn", "bus",
               "amcl", "deploy", "demo", "costmap_e2e", "agent")


def pytest_collection_modifyitems(items):
    def rank(item) -> int:
        parts = item.nodeid.split("/")
        return _LONG_FIRST.index(parts[1]) if len(parts) > 2 and parts[1] in _LONG_FIRST else len(_LONG_FIRST)

    items.sort(key=rank)  # stable: the order inside each folder is kept


# move_base's start() shortens the interpreter's thread switch interval for its whole process (it hands
# the GIL to the bus threads every 1 ms). A test that starts move_base in the test process must not leave
# that to the tests after it on the same worker: every later test then ran up to twice as slowly.
@pytest.fixture(autouse=True)
def _switch_interval():
    import sys

    before = sys.getswitchinterval()
    yield
    sys.setswitchinterval(before)


def pytest_configure(config):
    """A suite started in the background by a non-interactive shell inherits SIGINT ignored, and so would
    every process the tests start (nodes an agent stops with SIGINT, tools a test stops with Ctrl-C).

    Each xdist worker picks loopback ports from its own slice of common.ports' range (and so do the processes
    its tests start, through the environment): two workers picking the same free port a second apart made one
    test's master fail with "Address already in use" (ci105)."""
    import signal

    from common.ports import HIGH, LOW

    # from the config, not the environment: a pytest started by a test inherits its worker's PYTEST_XDIST_WORKER
    global _WORKER
    if hasattr(config, "workerinput"):
        _WORKER = config.workerinput["workerid"]
    elif not getattr(config.option, "numprocesses", 0):
        _WORKER = "main"

    worker, count = os.environ.get("PYTEST_XDIST_WORKER", ""), int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if worker.startswith("gw") and count > 1:
        k, width = int(worker[2:]), (HIGH - LOW) // count
        os.environ["ZENAV_PORT_RANGE"] = f"{LOW + k * width}-{LOW + (k + 1) * width}"

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


# ZENAV_TEST_TIMELINE=FILE: each test's start and end (wall clock) with the CPU its worker and that worker's
# children used meanwhile, one JSON line per test appended to FILE by every worker — where a parallel run's
# time goes (README, "Test suite time"; `python bench/suite_timeline.py FILE` sums it up).
_TIMELINE = os.environ.get("ZENAV_TEST_TIMELINE", "")
_started: dict[str, tuple[float, float]] = {}
_WORKER: str | None = None  # this process's name in the timeline, None when it runs no test (pytest_configure)


def _cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _timed() -> bool:
    """A timeline is asked for, and this process runs tests (not xdist's controller, which hears of them)."""
    return bool(_TIMELINE) and _WORKER is not None


def pytest_runtest_logstart(nodeid, location):
    if _timed():
        import time

        _started[nodeid] = (time.time(), _cpu())


def pytest_runtest_logfinish(nodeid, location):
    if _timed() and nodeid in _started:
        import json
        import time

        t0, c0 = _started.pop(nodeid)
        line = json.dumps({"worker": _WORKER, "test": nodeid,
                           "start": t0, "end": time.time(), "cpu_s": _cpu() - c0})
        with open(_TIMELINE, "a") as f:
            f.write(line + "\n")
