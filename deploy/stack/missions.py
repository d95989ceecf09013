"""Missions: a list of poses driven one after the other (``zenav goal --waypoints FILE [--loop]``), each
leg sent and followed as ``zenav goal`` sends one goal (``deploy.stack.goals.send_goal``).

The file (YAML)::

    frame: map                 # the frame of every waypoint that names none (default map)
    waypoints:
      - {x: 2.0, y: 1.4, yaw: 1.57, name: door}
      - {x: -2.2, y: 0.0}      # yaw 0 when left out
      - {x: 0.5, y: -1.0, yaw: 3.14, frame: odom}

A leg that fails (aborted, rejected) is reported with move_base's reason and the mission goes on to the
next waypoint, or stops there with ``stop_on_failure``. No answer from move_base at all ends the mission.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from common.config import ConfigError, load_params, param, read_yaml


@dataclass(frozen=True)
class Waypoint:
    x: float = param(unit="m", doc="position in ``frame``")
    y: float = param(unit="m")
    yaw: float = param(0.0, unit="rad")
    frame: str = param("map", doc="TF frame of the pose")
    name: str = param("", doc="a label for the leg's lines")

    def validate(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.yaw)):
            raise ValueError(f"x, y and yaw must be finite numbers, got ({self.x}, {self.y}, {self.yaw})")

    def label(self) -> str:
        where = f"({self.x:.2f}, {self.y:.2f}, {self.yaw:.2f}) in {self.frame}"
        return f"'{self.name}' {where}" if self.name else where


@dataclass(frozen=True)
class _MissionFile:
    frame: str = param("map", doc="frame of every waypoint that names none")
    waypoints: list = param(default_factory=list, doc="the poses, in order")


def load_mission(path: str | Path) -> list[Waypoint]:
    """The waypoints of a mission file; a bad file raises ConfigError naming the file, the waypoint and the key."""
    src = str(path)
    top = load_params(_MissionFile, read_yaml(path), src)
    if not top.waypoints:
        raise ConfigError(src, "waypoints", "no waypoint given (a list of {x: .., y: .., yaw: ..})")
    out = []
    for i, item in enumerate(top.waypoints):
        section = f"waypoints[{i}]"
        if not isinstance(item, dict):
            raise ConfigError(src, section, f"expected a mapping like {{x: 1.0, y: 2.0, yaw: 0.0}}, got {item!r}")
        missing = [k for k in ("x", "y") if k not in item]
        if missing:
            raise ConfigError(src, section, f"missing {' and '.join(missing)}")
        out.append(load_params(Waypoint, {"frame": top.frame, **item}, src, section))
    return out


@dataclass
class Leg:
    index: int  # 1-based, within its round
    waypoint: Waypoint
    code: int  # send_goal's: 0 reached, 1 failed, 2 no answer
    reason: str
    seconds: float


@dataclass
class MissionReport:
    legs: list[Leg] = field(default_factory=list)
    code: int = 0  # 0 every leg reached, 1 a leg failed or the mission was cancelled, 2 move_base never answered

    def summary(self) -> str:
        reached = sum(leg.code == 0 for leg in self.legs)
        failed = [f"leg {leg.index} {leg.waypoint.label()}: {leg.reason}" for leg in self.legs if leg.code != 0]
        tail = f"; failed: {'; '.join(failed)}" if failed else ""
        return f"mission: {reached} of {len(self.legs)} legs reached{tail}"


def run_mission(node, waypoints: list[Waypoint], timeout: float, echo=print,
                cancel: threading.Event | None = None, wait: float = 60.0, loop: bool = False,
                stop_on_failure: bool = False) -> MissionReport:
    """Drive ``waypoints`` in order (again and again with ``loop``, until ``cancel``); ``timeout`` per leg."""
    from deploy.stack.goals import send_goal

    report, n, rnd = MissionReport(), len(waypoints), 0
    quiet = lambda *_a, **_k: None  # noqa: E731  (send_goal's progress: the leg lines say it)
    while True:
        rnd += 1
        for i, wp in enumerate(waypoints, 1):
            if cancel is not None and cancel.is_set():
                report.code = 1
                echo("mission: cancelled")
                return report
            head = f"round {rnd}, leg {i}/{n}" if loop else f"leg {i}/{n}"
            echo(f"{head}: to {wp.label()}")
            t0 = time.monotonic()
            code, st = send_goal(node, wp.x, wp.y, wp.yaw, wp.frame, timeout, quiet, cancel, wait)
            took = time.monotonic() - t0
            reason = (st.reason if st is not None else "") or ("no answer from move_base" if code == 2 else "")
            report.legs.append(Leg(i, wp, code, reason, took))
            if code == 0:
                echo(f"{head}: reached in {took:.0f} s" + (f" ({st.distance_to_goal_m:.2f} m off)" if st else ""))
                continue
            echo(f"{head}: FAILED after {took:.0f} s: {reason or 'no reason given'}")
            if code == 2:  # move_base is not there (or not answering): the next legs would wait the same
                report.code = 2
                return report
            report.code = 1
            if stop_on_failure or (cancel is not None and cancel.is_set()):
                return report
        if not loop:
            return report
