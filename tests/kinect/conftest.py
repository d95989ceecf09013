"""Fixtures for the Kinect tests: the fake libfreenect_sync (fake_freenect_sync.c) compiled with ``cc`` at
test time, and a private loopback bus with the environment for node processes."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.support import free_port

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


@pytest.fixture(scope="session")
def fake_lib(tmp_path_factory) -> str:
    """Path of the compiled fake libfreenect_sync (skips only when there is no C compiler)."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler (cc) to build the fake libfreenect_sync")
    out = tmp_path_factory.mktemp("freenect") / "libfake_freenect_sync.so"
    subprocess.run([cc, "-shared", "-fPIC", "-O1", "-o", str(out), str(HERE / "fake_freenect_sync.c")],
                   check=True, capture_output=True, text=True, timeout=60)
    return str(out)


@pytest.fixture
def bus(robot_name):
    """The test's Zenoh peer (loopback, multicast off) and the environment for node / agent processes."""
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port, child_port = free_port(), free_port()
    node = Node("kinect_test", config=BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",),
                                                multicast=False), use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}", "ZENAV_LISTEN": f"tcp/127.0.0.1:{child_port}",
           "PYTHONPATH": str(REPO)}
    for k in ("ZENAV_USE_SIM_TIME", "FAKE_FREENECT_NO_DEVICE", "FAKE_FREENECT_UNPLUG_FILE"):
        env.pop(k, None)
    yield node, env
    node.close()
