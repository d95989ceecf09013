"""Helpers for the costmap / merged-scan end-to-end tests: processes on a private loopback Zenoh bus
(multicast off), killed with their whole process trees, and the room world's true geometry."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import psutil
import yaml

REPO = Path(__file__).resolve().parents[2]
ROOM = REPO / "robot_side" / "worlds" / "room.yaml"


def cme_wait(cond, timeout: float, what: str, procs=(), period: float = 0.05):
    """Poll ``cond()`` until truthy (returned); fail early with its log when a process died."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        v = cond()
        if v:
            return v
        for p in procs:
            assert p.alive(), f"{p.name} exited ({p.proc.returncode}) waiting for {what}:\n{p.log()[-4000:]}"
        time.sleep(period)
    logs = "".join(f"\n--- {p.name}\n{p.log()[-3000:]}" for p in procs)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}{logs}")


class CmeProc:
    """A process in its own session; ``stop()`` ends it and every descendant seen."""

    def __init__(self, name: str, argv: list[str], env: dict, log: Path) -> None:
        self.name, self.out = name, log
        self.seen: set[int] = set()
        with open(log, "wb") as o:
            self.proc = subprocess.Popen(argv, stdout=o, stderr=subprocess.STDOUT, env=env, cwd=REPO,
                                         start_new_session=True)

    def alive(self) -> bool:
        self._note_children()
        return self.proc.poll() is None

    def log(self) -> str:
        return self.out.read_text(errors="replace") if self.out.exists() else ""

    def _note_children(self) -> None:
        with contextlib.suppress(psutil.Error):
            self.seen.update(c.pid for c in psutil.Process(self.proc.pid).children(recursive=True))

    def stop(self, grace: float = 15.0) -> None:
        self._note_children()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(grace)
        for pid in (self.proc.pid, *self.seen):  # the agents start each node in its own session
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(5)


def robot_agent_argv(config: str, robot: str, *extra: str) -> list[str]:
    return [sys.executable, "-m", "robot_side.agent", "--config", str(REPO / config), "--robot", robot,
            *extra]


class CmeRecorder:
    """Every message of one topic (callback queue)."""

    def __init__(self, node, topic: str, msg_type, queue_size: int = 10000) -> None:
        self.items: list = []
        self.lock = threading.Lock()
        self.sub = node.subscribe(topic, msg_type, callback=self._add, mode="queue", queue_size=queue_size)

    def _add(self, msg) -> None:
        with self.lock:
            self.items.append(msg)

    def msgs(self) -> list:
        with self.lock:
            return list(self.items)

    def __len__(self) -> int:
        with self.lock:
            return len(self.items)


def map_from_odom(truth: list, odom: list):
    """map <- odom (Pose2D) from a ground_truth and an odom message of the same simulator step
    (what fake_localization publishes), or None when no pair has arrived yet."""
    by_stamp = {round(m.header.stamp * 1e4): m for m in odom}
    for g in reversed(truth):
        o = by_stamp.get(round(g.header.stamp * 1e4))
        if o is not None:
            return g.pose2d.compose(o.pose2d.inverse())
    return None


# -- the room's true geometry -------------------------------------------------------------------------
@dataclass(frozen=True)
class RoomTruth:
    crate_center: tuple[float, float]
    crate_size: tuple[float, float]
    walls: tuple[tuple[float, float, float, float, float], ...]  # x0, y0, x1, y1, thickness

    @staticmethod
    def load(path: Path = ROOM) -> RoomTruth:
        spec = yaml.safe_load(path.read_text())
        (box,) = spec["boxes"]
        assert abs(float(box.get("yaw", 0.0))) < 1e-9, "the checks assume an axis-aligned crate"
        walls = tuple((*map(float, w["from"]), *map(float, w["to"]), float(w["thickness"]))
                      for w in spec["walls"])
        return RoomTruth(tuple(map(float, box["center"])), tuple(map(float, box["size"])), walls)

    @property
    def crate_min(self) -> np.ndarray:
        return np.array(self.crate_center) - np.array(self.crate_size) / 2

    @property
    def crate_max(self) -> np.ndarray:
        return np.array(self.crate_center) + np.array(self.crate_size) / 2

    def crate_distance(self, xy: np.ndarray) -> np.ndarray:
        """Distance of points (N, 2) to the crate's footprint (0 inside)."""
        d = np.maximum(np.maximum(self.crate_min - xy, xy - self.crate_max), 0.0)
        return np.hypot(d[:, 0], d[:, 1])

    def wall_distance(self, xy: np.ndarray) -> np.ndarray:
        """Distance of points (N, 2) to the nearest wall's footprint (0 inside)."""
        out = np.full(len(xy), np.inf)
        for x0, y0, x1, y1, th in self.walls:
            a, b = np.array([x0, y0]), np.array([x1, y1])
            t = np.clip(((xy - a) @ (b - a)) / float((b - a) @ (b - a)), 0.0, 1.0)
            d = np.hypot(*(xy - (a + t[:, None] * (b - a))).T) - th / 2
            out = np.minimum(out, np.maximum(d, 0.0))
        return out

    def surface_distance(self, xy: np.ndarray) -> np.ndarray:
        return np.minimum(self.crate_distance(xy), self.wall_distance(xy))
