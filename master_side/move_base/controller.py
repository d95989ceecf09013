"""Glue between the move_base state machine and a local planner (pure: data in, commands out).

The global plan is kept in the global frame (map) and handed to the local planner in the local
costmap's frame (odom) each cycle, so SLAM / localisation corrections of map→odom are followed.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, normalize_angles
from master_side.costmap.cost_values import LETHAL
from master_side.move_base.machine_types import ControlResult
from master_side.planning.local.base import LocalPlannerPlugin, velocity3


def transform_path(path: np.ndarray, tf: Pose2D) -> np.ndarray:
    """Apply a planar transform to an (N, 3) path."""
    if len(path) == 0:
        return path
    xy = tf.apply(path[:, :2])
    th = normalize_angles(path[:, 2] + tf.theta)
    return np.column_stack((xy, th))


class LocalController:
    """The ``contracts.Controller`` of ``MoveBaseMachine`` on top of a local planner."""

    def __init__(self, planner: LocalPlannerPlugin, footprint: np.ndarray) -> None:
        self.planner = planner
        self.footprint = np.asarray(footprint, float).reshape(-1, 2)
        self.global_plan = np.zeros((0, 3))
        self.local_pose: Pose2D | None = None  # robot pose in the local frame, set each cycle
        self.local_from_global: Pose2D | None = None
        self.costmap: tuple[np.ndarray, float, tuple[float, float]] | None = None  # the local costmap's
        # (grid uint8, resolution, (ox, oy))
        self.last: ControlResult | None = None
        self._sent_tf: Pose2D | None = None
        self._sent_plan_id = -1
        self._plan_id = 0

    def update(self, local_pose: Pose2D, local_from_global: Pose2D, costmap) -> None:
        self.local_pose, self.local_from_global, self.costmap = local_pose, local_from_global, costmap

    # -- protocol used by the state machine ------------------------------------------------------
    def set_plan(self, path: np.ndarray) -> None:
        self.global_plan = np.asarray(path, float).reshape(-1, 3)
        self._plan_id += 1

    def _sync_plan(self) -> None:
        tf = self.local_from_global
        moved = self._sent_tf is None or math.hypot(tf.x - self._sent_tf.x, tf.y - self._sent_tf.y) > 0.02 \
            or abs(tf.theta - self._sent_tf.theta) > 0.01
        if self._plan_id != self._sent_plan_id or moved:
            self.planner.set_plan(transform_path(self.global_plan, tf))
            self._sent_plan_id, self._sent_tf = self._plan_id, tf

    def compute(self, pose: Pose2D, velocity) -> ControlResult:
        if self.costmap is None:
            return ControlResult(reason="no local costmap received yet")
        if self.local_pose is None or self.local_from_global is None:
            return ControlResult(reason="robot pose in the local frame unknown")
        self._sync_plan()
        grid, res, origin = self.costmap
        r = self.planner.compute_velocity(self.local_pose, velocity3(velocity), grid, res, origin, self.footprint)
        self.last = ControlResult(velocity3(r.cmd), bool(r.ok), r.reason, r.trajectory)
        if not r.ok and not r.reason:
            self.last = ControlResult(velocity3(r.cmd), False, "local planner gave no command", r.trajectory)
        return self.last

    def goal_reached(self, pose: Pose2D, velocity) -> bool:
        if self.local_pose is None or len(self.global_plan) == 0 or self.local_from_global is None:
            return False
        self._sync_plan()
        return bool(self.planner.is_goal_reached(self.local_pose, tuple(velocity)))

    # -- recovery support --------------------------------------------------------------------------
    def footprint_blocked(self, pose_local: Pose2D) -> bool:
        """True if the footprint outline at ``pose_local`` touches a lethal local cell."""
        if self.costmap is None:
            return True
        grid, res, (ox, oy) = self.costmap
        fp = self.footprint
        pts = []
        for a, b in zip(fp, np.roll(fp, -1, axis=0)):
            n = max(2, int(np.hypot(*(b - a)) / res) + 1)
            pts.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
        world = pose_local.apply(np.vstack(pts))
        c = np.floor((world - [ox, oy]) / res).astype(int)
        ok = (c[:, 0] >= 0) & (c[:, 1] >= 0) & (c[:, 0] < grid.shape[1]) & (c[:, 1] < grid.shape[0])
        if not ok.all():
            return True
        cost = grid[c[:, 1], c[:, 0]]
        return bool((cost == LETHAL).any())
