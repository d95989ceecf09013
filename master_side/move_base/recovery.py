"""Recovery behaviours (pure): costmap reset and in-place rotation, as ROS's clear_costmap_recovery and
rotate_recovery, zenav's escape (``escape.py``), and move_base's default list or its ``recovery_behaviors``
parameter.

A behaviour has ``name``, ``enabled(params)``, ``start(now)`` and ``step(now, pose, velocity) ->
(cmd, done)``. Side effects (clearing costmaps, checking the footprint) go through callables the
node supplies, so the behaviours are testable without a bus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from common.config import ConfigError, load_params, param
from common.geometry import Pose2D, normalize_angle
from master_side.move_base.contracts import Recovery
from master_side.move_base.escape import ESCAPE_TYPES, EscapeParams, View
from master_side.move_base.escape_recovery import EscapeRecovery

CLEAR_TYPES = ("clear_costmap_recovery/ClearCostmapRecovery", "ClearCostmapRecovery")
ROTATE_TYPES = ("rotate_recovery/RotateRecovery", "RotateRecovery")


class ClearCostmapRecovery:
    """Reset obstacle layers outside a square of side ``reset_distance`` around the robot (0 = all)."""

    def __init__(self, clear: Callable[..., None], reset_distance: float, name: str = "",
                 affected_maps: str = "both") -> None:
        self._clear, self.reset_distance, self.affected_maps = clear, reset_distance, affected_maps
        self.name = name or f"clear costmaps beyond {reset_distance:.1f} m"

    def enabled(self, params) -> bool:
        return True

    def start(self, now: float) -> None:
        if self.affected_maps == "both":
            self._clear(self.reset_distance)
        else:
            self._clear(self.reset_distance, self.affected_maps)

    def step(self, now: float, pose: Pose2D, velocity) -> tuple[tuple[float, float, float], bool]:
        return (0.0, 0.0, 0.0), True


@dataclass(frozen=True)
class RotateLimits:
    """rotate_recovery reads these from the TrajectoryPlannerROS namespace (ROS defaults)."""

    max_rotational_vel: float = 1.0
    min_in_place_rotational_vel: float = 0.4
    acc_lim_th: float = 3.2
    yaw_goal_tolerance: float = 0.10


class RotateRecovery:
    """Turn in place one full revolution (rotate_recovery): the speed lets the robot stop where it
    started, sqrt(2 * acc * angle left) within [min, max]; if the footprint would touch an obstacle
    anywhere on the rest of the turn (``blocked(pose, yaws)``), the behaviour ends at once, as ROS's does.
    Skipped when clearing_rotation_allowed is false."""

    def __init__(self, limits: RotateLimits | float = RotateLimits(),
                 blocked: Callable[[Pose2D, np.ndarray], bool] | None = None,
                 sim_granularity: float = 0.017, timeout: float = 60.0, name: str = "rotate in place") -> None:
        if not isinstance(limits, RotateLimits):  # a single speed: constant-speed turn (tests)
            limits = RotateLimits(float(limits), float(limits), 1e9, 0.1)
        self.limits, self._blocked = limits, blocked
        self.sim_granularity, self.timeout, self.name = sim_granularity, timeout, name
        self._start_yaw: float | None = None
        self._got_180 = False
        self._t0 = 0.0

    def enabled(self, params) -> bool:
        return bool(params.clearing_rotation_allowed)

    def start(self, now: float) -> None:
        self._start_yaw, self._got_180, self._t0 = None, False, now

    def step(self, now: float, pose: Pose2D, velocity) -> tuple[tuple[float, float, float], bool]:
        lim = self.limits
        if self._start_yaw is None:
            self._start_yaw = pose.theta
        start = self._start_yaw
        if not self._got_180:
            to_180 = abs(normalize_angle(pose.theta - (start + math.pi)))
            left = math.pi + to_180
            self._got_180 = to_180 < lim.yaw_goal_tolerance
        else:
            left = abs(normalize_angle(pose.theta - start))
            if left <= lim.yaw_goal_tolerance:
                return (0.0, 0.0, 0.0), True
        if now - self._t0 > self.timeout:
            return (0.0, 0.0, 0.0), True
        if self._blocked is not None:
            yaws = pose.theta + np.arange(0.0, left, self.sim_granularity)
            if self._blocked(pose, yaws):
                return (0.0, 0.0, 0.0), True
        vel = min(max(math.sqrt(2.0 * lim.acc_lim_th * left), lim.min_in_place_rotational_vel),
                  lim.max_rotational_vel)
        return (0.0, 0.0, vel), False


@dataclass(frozen=True)
class ClearCostmapParams:
    reset_distance: float = param(3.0, lo=0.0, unit="m", doc="keep obstacles within this square")
    affected_maps: str = param("both", choices=("both", "local", "global"))


def default_recoveries(params, clear: Callable[..., None], blocked=None, circumscribed_radius: float = 0.0,
                       rotate: RotateLimits = RotateLimits()) -> list:
    """ROS move_base's default list: conservative reset, rotate, aggressive reset (keeps 4 ×
    the circumscribed radius around the robot, as move_base does), rotate."""
    return [
        ClearCostmapRecovery(clear, params.conservative_reset_dist, "conservative reset"),
        RotateRecovery(rotate, blocked),
        ClearCostmapRecovery(clear, 4.0 * circumscribed_radius, "aggressive reset"),
        RotateRecovery(rotate, blocked),
    ]


def recoveries_from_params(params, namespaces: dict, source: str, clear, blocked=None,
                           circumscribed_radius: float = 0.0, rotate: RotateLimits = RotateLimits(),
                           view: View | None = None, bare_footprint: np.ndarray | None = None,
                           log: Callable[[str], None] | None = None,
                           stalled: Callable[[], tuple[float, float] | None] | None = None,
                           on_stall: Callable[[tuple[float, float, float]], None] | None = None,
                           rotation_center_x: float = 0.0) -> list:
    """The ``recovery_behaviors`` list ([{name, type}], each name's parameters in ``namespaces``), or the
    default list when it is not set. An escape needs ``view`` (the local costmap and the robot's pose in
    it) and the robot's ``bare_footprint`` (unpadded); ``stalled`` tells it the command a stall stopped, and
    it tells ``on_stall`` the command of a move of its own that stalled; ``rotation_center_x``: where the
    base turns about (the local planner's parameter), for the escape's turns."""
    spec = params.recovery_behaviors
    if spec is None:
        return default_recoveries(params, clear, blocked, circumscribed_radius, rotate)
    if not isinstance(spec, list) or not all(isinstance(b, dict) and {"name", "type"} <= set(b) for b in spec):
        raise ConfigError(source, "recovery_behaviors", f"expected a list of {{name, type}}, got {spec!r}")
    names = [str(b["name"]) for b in spec]
    if len(set(names)) != len(names):
        raise ConfigError(source, "recovery_behaviors", f"behaviour names must be unique: {names}")
    out: list[Recovery] = []
    for b in spec:
        name, kind = str(b["name"]), str(b["type"])
        ns = namespaces.get(name) or {}
        if kind in CLEAR_TYPES:
            cp = load_params(ClearCostmapParams, {k: v for k, v in ns.items() if k in ("reset_distance",
                             "affected_maps")}, source, name)
            out.append(ClearCostmapRecovery(clear, cp.reset_distance, name, cp.affected_maps))
        elif kind in ROTATE_TYPES:
            out.append(RotateRecovery(rotate, blocked, float(ns.get("sim_granularity", 0.017)), name=name))
        elif kind in ESCAPE_TYPES:
            ep = load_params(EscapeParams, ns, source, name)
            fp = np.zeros((0, 2)) if bare_footprint is None else bare_footprint
            out.append(EscapeRecovery(view or (lambda: None), fp, ep, name, log, stalled, on_stall, rotation_center_x))
        else:
            raise ConfigError(source, f"recovery_behaviors[{names.index(name)}].type",
                              f"{kind!r} is not implemented (known: {CLEAR_TYPES[0]}, {ROTATE_TYPES[0]}, "
                              f"{ESCAPE_TYPES[0]})")
    return out
