"""Helpers for the agent tests: a loopback bus without multicast, agent subprocesses, event logs."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import psutil
import pytest
import yaml

from tests.support import free_port, wait_until  # noqa: F401

REPO = Path(__file__).resolve().parents[2]


def read_events(path: Path) -> list[tuple[str, str, int, float]]:
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 4:
            out.append((parts[0], parts[1], int(parts[2]), float(parts[3])))
    return out


def first(events, event: str, name: str) -> float | None:
    return next((t for e, n, _, t in events if e == event and n == name), None)


class Agent:
    """An agent process (``python -m robot_side.agent`` / ``master_side.agent``) for one test."""

    def __init__(self, tmp: Path, cfg: dict | str, robot: str, env: dict, kind: str = "robot",
                 extra_args: tuple = ()) -> None:
        self.tmp, self.robot = tmp, robot
        if isinstance(cfg, dict):
            self.config = tmp / f"{kind}.yaml"
            self.config.write_text(yaml.safe_dump(cfg, sort_keys=False))
        else:
            self.config = Path(cfg)
        self.out, self.err = tmp / "agent.out", tmp / "agent.err"
        module = "robot_side.agent" if kind == "robot" else "master_side.agent"
        with open(self.out, "wb") as o, open(self.err, "wb") as e:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", module, "--config", str(self.config), "--robot", robot, *extra_args],
                stdout=o, stderr=e, env=env, cwd=REPO, start_new_session=True)
        self.seen_pids: set[int] = set()

    def children(self) -> list[psutil.Process]:
        try:
            kids = psutil.Process(self.proc.pid).children(recursive=True)
        except psutil.Error:
            return []
        self.seen_pids.update(k.pid for k in kids)
        return kids

    def wait(self, timeout: float) -> int:
        return self.proc.wait(timeout)

    def stderr(self) -> str:
        return self.err.read_text(errors="replace")

    def stdout(self) -> str:
        return self.out.read_text(errors="replace")

    def cleanup(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        for pid in self.seen_pids:     # never leave processes behind, even when a test fails
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(pid, signal.SIGKILL)


@pytest.fixture
def bus(robot_name):
    """A test bus peer listening on a free loopback port (multicast off) and the env for agents."""
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port, agent_port = free_port(), free_port()
    cfg = BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",), multicast=False)
    node = Node("agent_test", config=cfg, use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}", "ZENAV_LISTEN": f"tcp/127.0.0.1:{agent_port}",
           "ZENAV_MODE": "peer", "PYTHONPATH": str(REPO)}
    env.pop("ZENAV_USE_SIM_TIME", None)
    yield node, env
    node.close()


@pytest.fixture
def agents(tmp_path):
    started: list[Agent] = []

    def start(cfg, robot, env, **kw) -> Agent:
        d = tmp_path / f"agent{len(started)}"
        d.mkdir()
        a = Agent(d, cfg, robot, env, **kw)
        started.append(a)
        return a

    yield start
    for a in started:
        a.cleanup()
