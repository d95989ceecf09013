"""Fixtures for the simulator end-to-end tests: the sim node (or `zenav robot`) as a subprocess on a
loopback bus without multicast, and a test peer that drives it and records what it publishes."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from tests.support import free_port, wait_until  # noqa: F401

REPO = Path(__file__).resolve().parents[2]


def write_world(tmp: Path, spec: dict, name: str = "world") -> Path:
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"name": name, **spec}, sort_keys=False))
    return path


def open_world(tmp: Path, wall_x: float | None = None, size: float = 12.0) -> Path:
    """A walled square of side 2*size, optionally a wall whose near face is at x = wall_x."""
    h = size
    walls = [{"from": [-h, -h], "to": [h, -h], "thickness": 0.1, "height": 2.0},
             {"from": [h, -h], "to": [h, h], "thickness": 0.1, "height": 2.0},
             {"from": [h, h], "to": [-h, h], "thickness": 0.1, "height": 2.0},
             {"from": [-h, h], "to": [-h, -h], "thickness": 0.1, "height": 2.0}]
    boxes = [] if wall_x is None else [{"center": [wall_x + 0.1, 0.0], "size": [0.2, 6.0], "height": 1.0}]
    return write_world(tmp, {"bounds": [-h - 0.5, -h - 0.5, h + 0.5, h + 0.5], "resolution": 0.05,
                             "start": [0.0, 0.0, 0.0], "walls": walls, "boxes": boxes})


class Recorder:
    """Every message of one topic with the wall time (monotonic) it arrived."""

    def __init__(self, node, topic: str, msg_type) -> None:
        self.items: list[tuple[float, object]] = []
        self.lock = threading.Lock()
        self.sub = node.subscribe(topic, msg_type, callback=self._add, mode="queue", queue_size=100000)

    def _add(self, msg) -> None:
        with self.lock:
            self.items.append((time.monotonic(), msg))

    def msgs(self) -> list:
        with self.lock:
            return [m for _, m in self.items]

    def timed(self) -> list:
        with self.lock:
            return list(self.items)

    def last(self):
        with self.lock:
            return self.items[-1][1] if self.items else None

    def __len__(self) -> int:
        with self.lock:
            return len(self.items)


class Proc:
    """A subprocess in its own session (killed with its children at cleanup), output to files."""

    def __init__(self, tmp: Path, argv: list[str], env: dict) -> None:
        self.out = tmp / "proc.log"
        with open(self.out, "wb") as o:
            self.proc = subprocess.Popen(argv, stdout=o, stderr=subprocess.STDOUT, env=env, cwd=REPO,
                                         start_new_session=True)

    def log(self) -> str:
        return self.out.read_text(errors="replace")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 20.0) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.proc.pid, signal.SIGKILL)  # never leave children behind
        return self.proc.wait(5)


@pytest.fixture
def bus(robot_name):
    """The test's own Zenoh peer (loopback, multicast off) and the environment for the processes."""
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port, child_port = free_port(), free_port()
    cfg = BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",), multicast=False)
    node = Node("sim_e2e_test", config=cfg, use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}", "ZENAV_LISTEN": f"tcp/127.0.0.1:{child_port}",
           "PYTHONPATH": str(REPO)}
    env.pop("ZENAV_USE_SIM_TIME", None)
    yield node, env
    node.close()


@pytest.fixture
def procs(tmp_path):
    started: list[Proc] = []

    def start(argv: list[str], env: dict) -> Proc:
        d = tmp_path / f"proc{len(started)}"
        d.mkdir()
        p = Proc(d, argv, env)
        started.append(p)
        return p

    yield start
    for p in started:
        p.stop()


@pytest.fixture
def sim(bus, procs, tmp_path):
    """start(cfg, *args) -> Proc: ``python -m robot_side.sim.node --config <cfg as tmp yaml> *args``."""
    _, env = bus

    def start(cfg: dict, *args: str) -> Proc:
        path = tmp_path / f"sim{len(list(tmp_path.glob('sim*.yaml')))}.yaml"
        path.write_text(yaml.safe_dump(cfg, sort_keys=False))
        return procs([sys.executable, "-m", "robot_side.sim.node", "--config", str(path), *args], env)

    return start


def publisher_matched(pub, timeout: float = 30.0, what: str = "the simulator's subscription") -> None:
    """Wait until a zenav Publisher has a matching subscriber (so a single message is not lost)."""
    wait_until(lambda: pub._pub.matching_status.matching, timeout, what)
