"""Recorded data on the bus: `zenav play` (ROS1 bag, CARMEN log, MCAP) and `zenav record` (MCAP).

Every reader yields ``LogRecord``s in log-time order; the player publishes them."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LogRecord:
    stamp: float  # log time of the message, seconds (the clock the player publishes)
    topic: str    # zenav topic name without the robot prefix: "scan", "odom", "tf", "tf_static", ...
    msg: object   # a common.messages dataclass
