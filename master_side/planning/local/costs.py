"""Trajectory cost functions (base_local_planner TrajectoryCostFunction style).

Each has ``scale``, ``prepare(ctx) -> bool`` (False: skip this cycle) and ``score(trajs) -> (S,)``
where a negative value rejects the trajectory. Lower is better; the planner sums ``scale * score``.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from scipy import ndimage

from master_side.planning.grid import INSCRIBED, LETHAL
from master_side.planning.local.map_grid import (
    ScoringContext,
    angle_diff,
    footprint_outline,
    footprint_radii,
)
from master_side.planning.local.trajectories import Trajectories

REJECT = -1.0


class CostFunction:
    """Base: a named, scaled trajectory score."""

    name = "Cost"

    def __init__(self, scale: float = 1.0):
        self.scale = float(scale)
        self.ctx: ScoringContext | None = None

    def prepare(self, ctx: ScoringContext) -> bool:
        self.ctx = ctx
        return True

    def score(self, trajs: Trajectories) -> np.ndarray:
        raise NotImplementedError


class ObstacleCost(CostFunction):
    """Max costmap cost under the footprint along each trajectory; rejects LETHAL / unknown / off-map.

    Like base_local_planner's footprintCost: the centre cell must be below INSCRIBED, the footprint
    outline must not touch a LETHAL or NO_INFORMATION cell. The outline is only rasterised for poses
    within reach of a non-free cell; elsewhere every footprint cell is FREE and the centre cost is
    exact. Reach is judged by the chessboard distance to the nearest lethal cell, a lower bound of the
    Euclidean one (so no pose that could touch is skipped) that is five times cheaper to compute.
    """

    name = "ObstacleCost"

    def __init__(self, scale: float = 1.0):
        super().__init__(scale)
        self._key = None

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        g = ctx.grid
        key = (g.shape, zlib.crc32(np.ascontiguousarray(g)), float(ctx.resolution), ctx.footprint.tobytes())
        if key == self._key:  # the same costmap as the last call (several checks in one cycle)
            return True
        blocked = g >= LETHAL
        self.clear = (
            ndimage.distance_transform_cdt(~blocked, metric="chessboard") * ctx.resolution
            if blocked.any()
            else np.full(g.shape, np.inf)
        )
        soft = (g > 0) & (g < LETHAL)
        # the farthest an inflated cell lies from a lethal one (Euclidean <= sqrt(2) x chessboard)
        self.extent = (
            math.sqrt(2.0) * float(self.clear[soft].max()) if soft.any() and blocked.any()
            else (np.inf if soft.any() else 0.0)
        )
        self.inscribed, self.circumscribed = footprint_radii(ctx.footprint)
        self.outline = footprint_outline(ctx.footprint, ctx.resolution)
        self._key = key
        return True

    def score(self, trajs: Trajectories) -> np.ndarray:
        ctx = self.ctx
        s, t = trajs.poses.shape[:2]
        pts = trajs.poses.reshape(-1, 3)
        r, c, inside = ctx.cells(pts[:, :2])
        centre = ctx.grid[r, c].astype(np.int64)
        clear = self.clear[r, c]
        res = ctx.resolution
        bad = ~inside | (centre >= INSCRIBED)
        cost = centre.astype(float)
        # A pose equal to the previous one of its trajectory (padding after a short trajectory, a robot
        # standing still) has the same outline: rasterise it once.
        w = ctx.grid.shape[1]
        same = np.zeros((s, t), bool)
        poses = trajs.poses
        same[:, 1:] = (poses[:, 1:] == poses[:, :-1]).all(axis=2)
        first = ~same
        src = np.maximum.accumulate(np.where(first, np.arange(t)[None, :], 0), axis=1)
        src = (src + (np.arange(s) * t)[:, None]).ravel()
        first = first.ravel()
        # outline cells can be LETHAL only within the circumscribed radius; they can cost > 0 within
        # circumscribed + inflation extent. Check the first band, drop rejected trajectories, then the second.
        band = self.circumscribed + 1.5 * res  # cell-centre distances: allow for the discretisation
        flat = ctx.grid.ravel()
        outline_bad = np.zeros(s * t, bool)
        outline_cost = np.zeros(s * t)
        # the cost-only band samples every other outline point (about 2 cells apart): cheaper, and
        # the inflation cost changes little over one cell
        for lo, hi, outline in ((-np.inf, band, self.outline), (band, band + self.extent, self.outline[::2])):
            dead = np.repeat(bad.reshape(s, t).any(axis=1), t)
            near = np.flatnonzero(first & ~dead & (clear <= hi) & (clear > lo))
            if near.size == 0:
                continue
            p = pts[near]
            cs, sn = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
            ox, oy = outline[:, 0][None, :], outline[:, 1][None, :]
            orr, occ, oin = ctx.cells_xy(p[:, 0:1] + cs * ox - sn * oy, p[:, 1:2] + sn * ox + cs * oy)
            oc = flat[orr * w + occ]
            outline_bad[near] = (~oin | (oc >= LETHAL)).any(axis=1)
            outline_cost[near] = oc.max(axis=1)
            bad |= outline_bad[src]
        bad |= outline_bad[src]
        cost = np.maximum(cost, outline_cost[src])
        bad = bad.reshape(s, t)
        if t > 1 and bad[:, 0].any():
            _allow_escape(bad, clear.reshape(s, t))
        bad_t = bad.any(axis=1)
        out = cost.reshape(s, t).max(axis=1)
        out[bad_t] = REJECT
        return out


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

    def points(self, trajs: Trajectories) -> np.ndarray:
        p = trajs.poses
        if self.forward == 0.0:
            return p[..., :2]
        return p[..., :2] + self.forward * np.stack((np.cos(p[..., 2]), np.sin(p[..., 2])), axis=-1)

    def score(self, trajs: Trajectories) -> np.ndarray:
        d = self.distances()
        r, c, inside = self.ctx.cells(self.points(trajs))
        vals = np.where(inside, d[r, c], np.inf) * self.ctx.resolution
        last = vals[:, -1]
        off = ~inside.all(axis=1)
        if self.stop_on_failure:
            bad = ~np.isfinite(vals).all(axis=1)
        else:  # off-map still rejects; an impossible end point costs what ROS gives it (the map size)
            bad = np.zeros(len(last), bool)
            last = np.where(np.isfinite(last), last, self.ctx.grid.size * self.ctx.resolution)
        return np.where(off | bad, REJECT, last)


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


def _allow_escape(bad: np.ndarray, clear: np.ndarray) -> None:
    """The robot already touches an obstacle (the padded footprint at its current pose, shared by every
    trajectory): rejecting every move would wedge it. Accept a trajectory whose leading in-contact
    poses never get closer to the nearest obstacle and which leaves contact within half its length;
    moves that stay in contact or push on are still rejected. ``bad`` (S, T) is edited in place."""
    lead = np.logical_and.accumulate(bad, axis=1)
    n_lead = lead.sum(axis=1)
    steps = np.diff(clear, axis=1)
    closer = np.concatenate((np.zeros((len(bad), 1), bool), steps < -1e-9), axis=1) & lead
    ok = (n_lead < bad.shape[1] / 2) & ~closer.any(axis=1)
    bad[ok[:, None] & lead] = False
