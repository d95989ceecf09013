"""TrajectoryPlanner's trajectory cost and oscillation flags (base_local_planner/trajectory_planner.cpp).

``TrajectoryCost.score`` gives, for all trajectories at once, ROS's cost

    path_distance_bias * path_dist + goal_distance_bias * goal_dist + occdist_scale * occ_cost

(negative = invalid): occ_cost is the largest footprint / centre cost along the trajectory (the
footprint may not touch a LETHAL or unknown cell); path_dist / goal_dist are the MapGrid flood-fill
distances (cells) at the trajectory's last point, and a trajectory with a point on an obstacle or on a
cell with no way to the plan is invalid. ``meter_scoring`` multiplies the two biases by the resolution.
``heading_scoring`` evaluates the distances at ``heading_scoring_timestep`` only and adds 0.3 x the angle
between the heading there and the direction to the farthest plan point in line of sight;
``simple_attractor`` uses the squared distance of the last point to the plan's end instead.
"""

from __future__ import annotations

import math

import numpy as np

from master_side.planning.grid import INSCRIBED
from master_side.planning.local.costs import ObstacleCost
from master_side.planning.local.scoring_context import ScoringContext, angle_diff
from master_side.planning.local.trajectories import Trajectories

HEADING_WEIGHT = 0.3  # trajectory_planner.cpp: the fixed weight of heading_diff


class TrajectoryCost:
    """The TrajectoryPlanner cost over all samples (numpy); ``reason`` says why the last call rejected all."""

    def __init__(self, params) -> None:
        self.p = params
        self.obstacle = ObstacleCost()
        self.reason = ""

    def _biases(self, ctx: ScoringContext) -> tuple[float, float]:
        k = ctx.resolution if self.p.meter_scoring else 1.0
        return self.p.path_distance_bias * k, self.p.goal_distance_bias * k

    def score(self, trajs: Trajectories, ctx: ScoringContext) -> np.ndarray:
        p = self.p
        n = len(trajs)
        self.obstacle.prepare(ctx)
        occ = self.obstacle.score(trajs)
        hit = occ < 0
        nopath: np.ndarray
        if p.simple_attractor:
            end = trajs.poses[:, -1, :2] - ctx.plan[-1, :2]
            goal, path, heading = (end ** 2).sum(axis=1), np.zeros(n), np.zeros(n)
            nopath = np.zeros(n, bool)
        else:
            path_map, goal_map = ctx.path_distance(), ctx.goal_distance()
            pts = trajs.poses
            if p.heading_scoring:
                k = self._heading_index(trajs)
                pts = pts[:, k:k + 1] if k is not None else pts[:, :0]
            r, c, inside = ctx.cells(pts[..., :2])
            pd = np.where(inside, path_map[r, c], np.inf)
            gd = np.where(inside, goal_map[r, c], np.inf)
            if pts.shape[1] == 0:  # the scoring time lies beyond sim_time: ROS scores zeros
                path, goal, nopath = np.zeros(n), np.zeros(n), np.zeros(n, bool)
            else:
                nopath = np.asarray(~(np.isfinite(pd).all(axis=1) & np.isfinite(gd).all(axis=1)))
                path, goal = pd[:, -1], gd[:, -1]
            heading = self._heading_diff(pts, ctx) if p.heading_scoring else np.zeros(n)
        pb, gb = self._biases(ctx)
        with np.errstate(invalid="ignore"):
            cost = pb * path + gb * goal + p.occdist_scale * np.maximum(occ, 0.0) + HEADING_WEIGHT * heading
        cost[hit | nopath] = -1.0
        self.reason = ""
        if n and (hit | nopath).all():
            self.reason = (f"all {n} trajectories rejected: {int(hit.sum())} hit an obstacle, "
                           f"{int((nopath & ~hit).sum())} pass a cell with no way to the plan")
        return cost

    def collision_free(self, trajs: Trajectories, ctx: ScoringContext) -> np.ndarray:
        self.obstacle.prepare(ctx)
        return self.obstacle.score(trajs) >= 0

    def lookahead_goal_distance(self, trajs: Trajectories, ctx: ScoringContext, lookahead: float) -> np.ndarray:
        """Goal distance (cells) of the point ``lookahead`` ahead of each end pose; inf off the map, the
        map size + 1 where the flood fill did not reach (ROS's unreachable value, still comparable)."""
        end = trajs.poses[:, -1]
        xy = end[:, :2] + lookahead * np.column_stack((np.cos(end[:, 2]), np.sin(end[:, 2])))
        r, c, inside = ctx.cells(xy)
        d = ctx.goal_distance()[r, c]
        d = np.where(np.isfinite(d), d, float(ctx.grid.size + 1))
        return np.where(inside, d, np.inf)

    def _heading_index(self, trajs: Trajectories) -> int | None:
        """Point index whose time lies in [heading_scoring_timestep, + dt) (all samples share dt here)."""
        steps = trajs.poses.shape[1]
        dt = self.p.sim_time / steps
        k = math.ceil(self.p.heading_scoring_timestep / dt - 1e-9)
        return k if k < steps else None

    def _heading_diff(self, pts: np.ndarray, ctx: ScoringContext) -> np.ndarray:
        """|angle| from each point's heading to the farthest plan point with a clear line of sight."""
        out = np.full(len(pts), np.inf)
        if pts.shape[1] == 0:
            return np.zeros(len(pts))
        plan = ctx.plan[::-1, :2]
        pr, pc, pin = ctx.cells(plan)
        plan_cells = np.column_stack((pc, pr))[pin]
        centres = (plan_cells + 0.5) * ctx.resolution + ctx.origin
        for i, (x, y, th) in enumerate(pts[:, 0]):
            r, c, inside = ctx.cells(np.array([x, y]))
            if not inside:
                continue
            for (gc, gr), g in zip(plan_cells, centres):
                if _line_clear(ctx.grid, int(c), int(r), int(gc), int(gr)):
                    out[i] = abs(angle_diff(th, math.atan2(g[1] - y, g[0] - x)))
                    break
        return out


def _line_clear(grid: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> bool:
    """No LETHAL, INSCRIBED or unknown cell on the grid line between two cells (inclusive)."""
    n = max(abs(x1 - x0), abs(y1 - y0)) + 1
    xs = np.rint(np.linspace(x0, x1, n)).astype(int)
    ys = np.rint(np.linspace(y0, y1, n)).astype(int)
    return bool((grid[ys, xs] < INSCRIBED).all())


class TPOscillation:
    """TrajectoryPlanner's rotation / strafe flags. Two consecutive in-place choices in one direction
    forbid the other direction (``stuck_*``) until the robot has moved ``oscillation_reset_dist`` from
    where it last chose a move that is not forward."""

    def __init__(self, reset_dist: float) -> None:
        self.reset_dist = reset_dist
        self.reset()

    def reset(self) -> None:
        self.rotating_left = self.rotating_right = self.stuck_left = self.stuck_right = False
        self.strafe_left = self.strafe_right = self.stuck_left_strafe = self.stuck_right_strafe = False
        self.prev: np.ndarray | None = None

    def chose(self, cmd: np.ndarray, pose: np.ndarray) -> None:
        vx, vy, w = (float(v) for v in cmd)
        if not vx > 0:
            if w < 0:
                self.stuck_right |= self.rotating_right
                self.rotating_right = True
            elif w > 0:
                self.stuck_left |= self.rotating_left
                self.rotating_left = True
            elif vy > 0:
                self.stuck_right_strafe |= self.strafe_right
                self.strafe_right = True
            elif vy < 0:
                self.stuck_left_strafe |= self.strafe_left
                self.strafe_left = True
            self.prev = np.array(pose[:2], float)
        self.moved(pose)

    def moved(self, pose: np.ndarray) -> None:
        if self.prev is not None and math.hypot(*(pose[:2] - self.prev)) > self.reset_dist:
            prev = self.prev
            self.reset()
            self.prev = prev

    # LocalPlanner interface (the DWA-style oscillation cost object has these)
    def update(self, cmd: np.ndarray, pose: np.ndarray) -> None:
        self.chose(cmd, pose)
