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


# Longest modules first (longest processing time first, for two workers taking whole modules): a long
# module started late runs alone at the end while the other worker idles. The modules over ~10 s by name,
# in the order of their mean time in three full runs of 2026-11-27 (`--durations`, junit); then the
# folders of the other end-to-end tests; then everything else in collection order.
_LONGEST = ("fleet/test_fleet_netns", "monitor/test_monitor_web_tools", "logs/test_record_play_monitor",
            "reliability/test_link_faults", "nav_e2e/test_nav_e2e_corridor_trajectory",
            "nav_e2e/test_nav_e2e_recovery", "logs/test_play_slam_online", "nav_e2e/test_nav_e2e_room_dwa",
            "slam_e2e/test_slam_e2e_room", "nav_e2e/test_nav_e2e_room_trajectory",
            "nav_e2e/test_nav_e2e_corridor_dwa", "slam_e2e/test_slam_e2e_hector", "sim_e2e/test_sim_e2e_agent",
            "amcl/test_amcl_e2e", "barn/test_barn_bus", "bus/test_fuzz_nodes", "demo/test_demo_headless",
            "sim_mujoco/test_mujoco_barn_bus", "barn/test_barn_blind_robot", "monitor/test_monitor_fleet_robots",
            "sim_e2e/test_sim_e2e_node", "monitor/test_monitor_not_mirrored", "deploy/test_deploy_doctor",
            "bus/test_cli", "planning/test_fast_paths", "monitor/test_recording", "test_codec",
            "planning/test_spin_in_gap", "kinect/test_kinect_node", "agent/test_robot_agent")
_LONG_FOLDERS = ("nav_e2e", "fleet", "sim_e2e", "logs", "monitor", "reliability", "slam_e2e", "barn", "bus",
                 "amcl", "deploy", "demo", "costmap_e2e", "agent")


def pytest_collection_modifyitems(items):
    def rank(item) -> int:
        module = item.nodeid.split("::")[0].removeprefix("tests/").removesuffix(".py")
        if module in _LONGEST:
            return _LONGEST.index(module)
        parts = module.split("/")
        folder = len(_LONG_FOLDERS)
        if len(parts) > 1 and parts[0] in _LONG_FOLDERS:
            folder = _LONG_FOLDERS.index(parts[0])
        return len(_LONGEST) + folder

    items.sort(key=rank)  # stable: the order inside each module is kept


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
    every process the tests start (nodes an agent stops with SIGINT, tools a test stops with Ctrl-C)."""
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
