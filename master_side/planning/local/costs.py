"""Trajectory cost functions (base_local_planner TrajectoryCostFunction style).

Each has ``scale``, ``prepare(ctx) -> bool`` (False: skip this cycle) and ``score(trajs) -> (S,)``
where a negative value rejects the trajectory. Lower is better; the planner sums ``scale * score``.
"""

from __future__ import annotations

import math

import numpy as np

from master_side.planning.local.cost_base import REJECT, CostFunction  # noqa: F401 (re-exported)
from master_side.planning.local.obstacle_cost import ObstacleCost  # noqa: F401 (re-exported)
from master_side.planning.local.scoring_context import (
    ScoringContext,
    angle_diff,
)
from master_side.planning.local.traj_cells import all_inside, finite_end_values, last_cells, point_cells
from master_side.planning.local.trajectories import Trajectories


class MapGridCost(CostFunction):
    """base_local_planner's MapGridCostFunction: the flood-fill distance (see ``grid_distance``) of a
    trajectory point to the plan (``target="path"``) or to the local goal (``"goal"``), in metres
    (cells x resolution). The score is the value at the last point; ``stop_on_failure``: a trajectory
    with any point on an obstacle or unreachable cell is rejected. ``forward`` shifts each point that far
    ahead along its heading (DWA's alignment costs, which keep the nose on the path)."""

    name = "MapGrid"

    def __init__(self, scale: float = 1.0, target: str = "path", forward: float = 0.0,
                 stop_on_failure: bool = True):
        super().__init__(scale)
        self.target, self.forward, self.stop_on_failure = target, float(forward), stop_on_failure

    def distances(self) -> np.ndarray:
        return self.ctx.path_distance() if self.target == "path" else self.ctx.goal_distance()

    def score(self, trajs: Trajectories) -> np.ndarray:
        ctx = self.ctx
        d, res = self.distances().ravel(), ctx.resolution
        if self.stop_on_failure:  # every point must be on the map and on a reachable cell
            flat, inside = point_cells(trajs, ctx, self.forward)  # (T + 1, S)
            return finite_end_values(d, flat, inside, res, REJECT)
        # off-map still rejects; an impossible end point costs what ROS gives it (the map size)
        flat, inside = last_cells(trajs, ctx, self.forward)
        last = (d[flat] if inside is None else np.where(inside, d[flat], np.inf)) * res
        last = np.where(np.isfinite(last), last, ctx.grid.size * res)
        return np.where(all_inside(trajs, ctx, self.forward), last, REJECT)


class PathDistance(MapGridCost):
    """Flood-fill distance (m) from the trajectory end point to the local plan; rejects trajectories
    through obstacles or cells with no way to the plan."""

    name = "PathDistance"

    def __init__(self, scale: float = 1.0):
        super().__init__(scale, "path")

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        return len(ctx.plan) > 0


class GoalDistance(MapGridCost):
    """Flood-fill distance (m) from the trajectory end point to the local goal."""

    name = "GoalDistance"

    def __init__(self, scale: float = 1.0):
        super().__init__(scale, "goal")

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        return len(ctx.plan) > 0


class PathAlign(MapGridCost):
    """DWA: path distance of a point ``forward_point_distance`` ahead of each pose (not a rejecter);
    switched off once the robot is within that distance of the goal (dwa_planner.cpp, cheat_factor 1)."""

    name = "PathAlign"

    def __init__(self, scale: float = 1.0, forward_point_distance: float = 0.325):
        super().__init__(scale, "path", forward_point_distance, stop_on_failure=False)

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        far = math.hypot(*(ctx.goal[:2] - ctx.pose[:2])) > self.forward
        return len(ctx.plan) > 0 and self.forward > 0 and far


class GoalAlign(MapGridCost):
    """DWA: distance of the forward point to the local goal of the plan whose last pose is pushed
    ``forward_point_distance`` further along the robot -> goal direction (not a rejecter)."""

    name = "GoalAlign"

    def __init__(self, scale: float = 1.0, forward_point_distance: float = 0.325):
        super().__init__(scale, "goal", forward_point_distance, stop_on_failure=False)

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        return len(ctx.plan) > 0 and self.forward > 0

    def distances(self) -> np.ndarray:
        return self.ctx.goal_distance(front=self.forward)


class Twirling(CostFunction):
    """|w| of the sample: prefers trajectories that do not spin."""

    name = "Twirling"

    def score(self, trajs: Trajectories) -> np.ndarray:
        return np.abs(trajs.vels[:, 2])


class Oscillation(CostFunction):
    """DWA's OscillationCostFunction: rejects reversing a motion direction right after the robot
    reversed it once.

    After the chosen command flips the sign of an axis, only the new sign is allowed on that axis
    until the robot has moved ``reset_dist`` or turned ``reset_angle`` from where that happened. The
    strafe and rotation axes count only for commands that barely translate (|vx| <= min_trans_vel).
    """

    name = "Oscillation"

    def __init__(self, reset_dist: float = 0.05, reset_angle: float = 0.2, eps: float = 1e-3,
                 min_trans_vel: float = 0.1):
        super().__init__(1.0)
        self.reset_dist, self.reset_angle, self.eps = reset_dist, reset_angle, eps
        self.min_trans_vel = min_trans_vel
        self.reset()

    def reset(self) -> None:
        self.last_sign = np.zeros(3)
        self.allowed = np.zeros(3)  # 0: any sign, else the only sign allowed on that axis
        self.anchor: np.ndarray | None = None

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        if self.anchor is not None:
            moved = math.hypot(*(ctx.pose[:2] - self.anchor[:2]))
            if moved >= self.reset_dist or abs(angle_diff(ctx.pose[2], self.anchor[2])) >= self.reset_angle:
                self.allowed[:] = 0.0
                self.anchor = None
        return bool(self.allowed.any())

    def score(self, trajs: Trajectories) -> np.ndarray:
        sg = np.sign(np.where(np.abs(trajs.vels) > self.eps, trajs.vels, 0.0))
        wrong = ((self.allowed[None, :] != 0) & (sg == -self.allowed[None, :])).any(axis=1)
        return np.where(wrong, REJECT, 0.0)

    def update(self, cmd: np.ndarray, pose: np.ndarray) -> None:
        """Record the command chosen this cycle (call after every cycle that moved the robot)."""
        sg = np.sign(np.where(np.abs(cmd) > self.eps, cmd, 0.0))
        if abs(float(cmd[0])) > self.min_trans_vel:  # translating: only the x axis is tracked
            sg[1:] = 0.0
        flipped = (sg != 0) & (self.last_sign != 0) & (sg != self.last_sign)
        if flipped.any():
            self.allowed[flipped] = sg[flipped]
            self.anchor = np.array(pose, dtype=float)
        self.last_sign = np.where(sg != 0, sg, self.last_sign)
