"""Recovery behaviours (pure): costmap reset and in-place rotation, as in ROS move_base's defaults.

A behaviour has ``name``, ``enabled(params)``, ``start(now)`` and ``step(now, pose, velocity) ->
(cmd, done)``. Side effects (clearing costmaps, checking the footprint) go through callables the
node supplies, so the behaviours are testable without a bus.
"""

from __future__ import annotations

import math
from typing import Callable

from common.geometry import Pose2D, normalize_angle


class ClearCostmapRecovery:
    """Reset obstacle layers outside a square of ``reset_distance`` around the robot (0 = all)."""

    def __init__(self, clear: Callable[[float], None], reset_distance: float, name: str = "") -> None:
        self._clear, self.reset_distance = clear, reset_distance
        self.name = name or f"clear costmaps beyond {reset_distance:.1f} m"

    def enabled(self, params) -> bool:
        return True

    def start(self, now: float) -> None:
        self._clear(self.reset_distance)

    def step(self, now: float, pose: Pose2D, velocity) -> tuple[tuple[float, float, float], bool]:
        return (0.0, 0.0, 0.0), True


class RotateRecovery:
    """Turn in place one full revolution (stops early if ``blocked(pose, angle)`` says the footprint
    would hit a lethal cell). Skipped when clearing_rotation_allowed is false."""

    def __init__(self, speed: float, blocked: Callable[[Pose2D], bool] | None = None,
                 timeout: float = 30.0) -> None:
        self.speed, self._blocked, self.timeout = speed, blocked, timeout
        self.name = "rotate in place"
        self._turned = 0.0
        self._last_yaw: float | None = None
        self._t0 = 0.0

    def enabled(self, params) -> bool:
        return bool(params.clearing_rotation_allowed)

    def start(self, now: float) -> None:
        self._turned, self._last_yaw, self._t0 = 0.0, None, now

    def step(self, now: float, pose: Pose2D, velocity) -> tuple[tuple[float, float, float], bool]:
        if self._last_yaw is not None:
            self._turned += abs(normalize_angle(pose.theta - self._last_yaw))
        self._last_yaw = pose.theta
        if self._turned >= 2 * math.pi - 0.05 or now - self._t0 > self.timeout:
            return (0.0, 0.0, 0.0), True
        if self._blocked is not None and self._blocked(Pose2D(pose.x, pose.y, pose.theta + 0.1)):
            return (0.0, 0.0, 0.0), True
        return (0.0, 0.0, self.speed), False


def default_recoveries(params, clear: Callable[[float], None], blocked=None,
                       circumscribed_radius: float = 0.0) -> list:
    """ROS move_base's default list: conservative reset, rotate, aggressive reset (keeps 4 ×
    the circumscribed radius around the robot, as move_base does), rotate."""
    return [
        ClearCostmapRecovery(clear, params.conservative_reset_dist, "conservative reset"),
        RotateRecovery(params.rotate_recovery_vel, blocked),
        ClearCostmapRecovery(clear, 4.0 * circumscribed_radius, "aggressive reset"),
        RotateRecovery(params.rotate_recovery_vel, blocked),
    ]
