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


# Longest modules first (seconds per module from `--durations=0` of a full two-worker run, 2026-11-27):
# with two workers taking whole modules, a long module left for the end runs while the other worker has
# nothing left to do. Modules not listed (each under ~8 s) follow in collection order.
_MODULE_S = {
    "fleet/test_fleet_netns.py": 164, "monitor/test_monitor_web_tools.py": 130,
    "logs/test_record_play_monitor.py": 100, "reliability/test_link_faults.py": 91,
    "nav_e2e/test_nav_e2e_corridor_trajectory.py": 62, "bus/test_fuzz_nodes.py": 52,
    "barn/test_barn_bus.py": 50, "nav_e2e/test_nav_e2e_corridor_dwa.py": 49, "logs/test_play_slam_online.py": 49,
    "nav_e2e/test_nav_e2e_room_trajectory.py": 46, "nav_e2e/test_nav_e2e_room_dwa.py": 45,
    "nav_e2e/test_nav_e2e_recovery.py": 45, "slam_e2e/test_slam_e2e_room.py": 40, "amcl/test_amcl_e2e.py": 35,
    "slam_e2e/test_slam_e2e_hector.py": 35, "sim_mujoco/test_mujoco_barn_bus.py": 35, "demo/test_demo_headless.py": 34,
    "sim_e2e/test_sim_e2e_agent.py": 33, "barn/test_barn_blind_robot.py": 30, "sim_e2e/test_sim_e2e_node.py": 24,
    "bus/test_cli.py": 22, "monitor/test_monitor_fleet_robots.py": 18, "deploy/test_deploy_doctor.py": 17,
    "test_codec.py": 15, "bus/test_cli_goal_input.py": 15, "monitor/test_recording.py": 15,
    "planning/test_fast_paths.py": 15, "sim_e2e/test_sim_e2e_jackal.py": 14, "agent/test_shipped_configs.py": 13,
    "logs/test_record_bus.py": 13, "deploy/test_cli_bad_args.py": 13, "slam/test_slam_bad_input.py": 12,
    "monitor/test_monitor_not_mirrored.py": 12, "kinect/test_kinect_node.py": 11, "agent/test_robot_agent.py": 11,
    "planning/test_spin_in_gap.py": 11, "costmap_e2e/test_costmap_e2e_merged_scan.py": 9,
    "costmap_e2e/test_costmap_e2e_sensor_health.py": 9, "lasers/test_hokuyo_node.py": 8,
}


def pytest_collection_modifyitems(items):
    def seconds(item) -> int:
        return _MODULE_S.get(item.nodeid.split("::")[0].removeprefix("tests/"), 0)

    items.sort(key=seconds, reverse=True)  # stable: the order inside each module and of the rest is kept


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
