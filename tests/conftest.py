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


# -- running the suite on two workers (pytest -n 2 --dist loadgroup, as .ci/run does) ------------------
# Tests that run a whole stack of processes (simulator + master, Chromium, network namespaces) go to one
# worker, one after the other, as they were written for (each may use both cores and assumes no second
# stack beside it); everything else runs on the other worker meanwhile, one test at a time.
STACK_TESTS = (
    "tests/nav_e2e/", "tests/slam_e2e/", "tests/sim_e2e/", "tests/costmap_e2e/", "tests/fleet/test_fleet_netns.py",
    "tests/reliability/", "tests/demo/", "tests/barn/test_barn_bus.py", "tests/barn/test_barn_blind_robot.py",
    "tests/amcl/test_amcl_e2e.py", "tests/logs/test_record_play_monitor.py", "tests/monitor/test_monitor_web",
    "tests/monitor/test_monitor_not_mirrored.py", "tests/monitor/test_monitor_fleet_robots.py",
    "tests/monitor/test_recording.py", "tests/bus/test_netns.py", "tests/deploy/test_deploy_doctor.py",
)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    if not getattr(config.option, "numprocesses", None):
        return
    for item in items:
        path = Path(str(item.fspath)).resolve().relative_to(REPO).as_posix()
        if path.startswith(STACK_TESTS) or item.get_closest_marker("netns"):
            item.add_marker(pytest.mark.xdist_group("stacks"))
