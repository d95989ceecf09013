"""Local planner interface (``LocalPlannerPlugin``, the Protocol move_base's controller calls, as ROS's
nav_core::BaseLocalPlanner) and the behaviour shared by DWA, trajectory rollout and pure pursuit
(``LocalPlanner``).

A cycle: prune the plan behind the robot, cut the part inside the local costmap, then either the goal
approach (inside ``xy_goal_tolerance``: brake, rotate in place to the goal yaw, stop) or sample
velocities, simulate, score and send the best. All in the local costmap's frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.cost_values import NO_INFORMATION
from master_side.planning.grid import check_grid
from master_side.planning.local.costs import ObstacleCost
from master_side.planning.local.reachable import reachable_plan
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.scoring_context import ScoringContext, angle_diff
from master_side.planning.local.trajectories import Trajectories, simulate

# Control cycles of command lag budgeted before the final in-place rotation brakes (see _rotation_speed).
LAG_CYCLES = 3.0
# Once the final in-place rotation has started, localisation jitter may carry the estimate a little past
# xy_goal_tolerance; the rotation goes on within this margin (m) instead of falling back to path
# following for a cycle, which commanded a turn the other way (ROS does fall back: deliberate difference).
ROTATION_HOLD_M = 0.05


Velocity = tuple[float, float, float]  # vx, vy, wz of the base


def velocity3(v) -> Velocity:
    """(vx, vy, wz) as three floats, from any 3-sequence (an array row, a tuple)."""
    return float(v[0]), float(v[1]), float(v[2])


@dataclass(frozen=True)
class LocalResult:
    cmd: tuple[float, float, float]  # (vx, vy, w) robot frame, m/s and rad/s
    ok: bool  # False: no valid command (cmd is a stop / brake command); see reason
    reason: str  # "" when ok and driving; why not moving otherwise
    trajectory: np.ndarray  # (T, 3) the chosen trajectory (empty if none)
    n_samples: int  # trajectories scored this cycle
    goal_approach: bool = False  # True while braking / rotating at the goal


@dataclass(frozen=True)
class Limits:
    """Velocity / acceleration limits and goal tolerances, common to both planners."""

    vx: tuple[float, float]  # (min, max) m/s
    vy: tuple[float, float]
    vth: tuple[float, float]  # (min, max) rad/s, signed
    min_in_place_vth: float  # |w| floor for rotating in place (friction)
    max_in_place_vth: float
    max_trans_vel: float
    min_trans_vel: float
    acc: tuple[float, float, float]  # m/s^2, m/s^2, rad/s^2
    sim_period: float  # s, one control cycle
    xy_goal_tolerance: float
    yaw_goal_tolerance: float
    latch_xy_goal_tolerance: bool
    trans_stopped_vel: float = 0.1
    rot_stopped_vel: float = 0.1
    rotation_center_x: float = 0.0  # m, in base_link: where the base turns about (see driven())
    cut_off_plan_min_reach: float = 0.0  # m; > 0: a cut-off plan is followed as far as it is open (reachable.py)


def driven(v: np.ndarray, rotation_center_x: float) -> np.ndarray:
    """Commanded velocities (..., 3) as the base moves under them, for the forward simulation. A base that
    turns about a point ``rotation_center_x`` ahead of base_link (behind: negative) moves base_link sideways
    at ``-rotation_center_x * w`` while it turns: the ICR kinematics of a skid-steered base (its longitudinal
    ICR coordinate; a differential drive, and ROS's planners, have 0)."""
    v = np.asarray(v, float)
    if not rotation_center_x:
        return v
    out = v.copy()
    out[..., 1] -= rotation_center_x * out[..., 2]
    return out


def goal_cut_off(ctx: ScoringContext, rejected: dict) -> str:
    """Why GoalDistance rejects, said where it is the main rejecter: the flood fill from the local goal
    never reaches the robot's cell, across obstacles (an obstacle or the inscribed band across the way on
    the local costmap, where the global costmap let the plan through) or across cells no sensor has seen;
    else ''."""
    if not rejected or max(rejected, key=rejected.get) != "GoalDistance":
        return ""
    r, c, inside = ctx.cells(ctx.pose[None, :2])
    if not inside[0] or np.isfinite(ctx.goal_distance()[r[0], c[0]]):
        return ""
    mg = ctx.map_grid()
    goal = mg.local_goal_cell(ctx.plan[:, :2])
    if goal is None:
        return ""
    through_unknown = mg.lattice.fill(mg.passable | (ctx.grid.ravel() == NO_INFORMATION), np.array([goal]))
    by = "unknown cells" if np.isfinite(through_unknown.reshape(ctx.grid.shape)[r[0], c[0]]) else "obstacles"
    return (f": the local goal ({ctx.goal[0]:.2f}, {ctx.goal[1]:.2f}) is cut off from the robot by {by} on the "
            f"local costmap")


def _toward(v: float, target: float, step: float) -> float:
    return min(v + step, target) if target > v else max(v - step, target)


class LocalPlannerPlugin(Protocol):
    """What ``move_base.controller.LocalController`` asks of a local planner, all in the local costmap's
    frame. ``footprint_padding``: the local costmap's padding (set by move_base)."""

    footprint_padding: float

    def set_plan(self, path: np.ndarray) -> None:
        """A new global plan, (N, 3) rows of (x, y, theta)."""

    def is_goal_reached(self, pose: Pose2D, velocity: Velocity) -> bool: ...

    def compute_velocity(self, pose: Pose2D, velocity: Velocity, grid: np.ndarray,
                         resolution: float, origin: tuple[float, float], footprint: np.ndarray) -> LocalResult:
        """The command for this cycle (``LocalResult.ok`` False with a reason when there is none)."""


class LocalPlanner:
    """Shared logic; subclasses provide ``_samples(vel)`` and ``_simulate(pose, vel, samples)`` (or their
    own ``_choose(ctx)``)."""

    def __init__(
        self, limits: Limits, scorer: ScoredSamplingPlanner, oscillation, prune_plan: bool = True
    ):
        self.limits = limits
        self.scorer = scorer
        self.oscillation = oscillation
        self.prune_plan = prune_plan
        self.collision = ObstacleCost()
        self._plan = np.zeros((0, 3))
        self._latched = False
        self._rot_dir = 0.0
        self._rot_cmd = 0.0  # last rotation speed commanded by the goal approach (along _rot_dir)
        # the local costmap's footprint_padding (move_base sets it): a planner that must tell the robot's
        # bare outline from the padded one uses it (the trajectory planner's escape, see its _back_up)
        self.footprint_padding = 0.0

    # --- interface -------------------------------------------------------------------------------------
    def set_plan(self, path: np.ndarray) -> None:
        """A new global plan (N, 3) in the local costmap's frame; resets goal latching and oscillation."""
        path = np.asarray(path, dtype=float).reshape(-1, 3)
        # A goal that moved only a little (the same plan re-expressed after a map->odom correction)
        # keeps the xy latch and the rotation direction; a new goal resets them.
        if len(self._plan) == 0 or len(path) == 0 or math.hypot(*(path[-1, :2] - self._plan[-1, :2])) > 0.25 \
                or abs(angle_diff(path[-1, 2], self._plan[-1, 2])) > 0.2:
            self._latched = False
            self._rot_dir = 0.0
            self.oscillation.reset()
        self._plan = path.copy()

    def is_goal_reached(self, pose: Pose2D, velocity: tuple[float, float, float]) -> bool:
        if len(self._plan) == 0:
            return False
        lim, goal = self.limits, self._plan[-1]
        xy_ok = self._latched or math.hypot(goal[0] - pose.x, goal[1] - pose.y) <= lim.xy_goal_tolerance
        yaw_ok = abs(angle_diff(goal[2], pose.theta)) <= lim.yaw_goal_tolerance
        vx, vy, w = velocity
        stopped = math.hypot(vx, vy) <= lim.trans_stopped_vel and abs(w) <= lim.rot_stopped_vel
        return xy_ok and yaw_ok and stopped

    def compute_velocity(
        self,
        pose: Pose2D,
        velocity: tuple[float, float, float],
        grid: np.ndarray,
        resolution: float,
        origin: tuple[float, float],
        footprint: np.ndarray,
    ) -> LocalResult:
        g = check_grid(grid, resolution)
        p, v = pose.as_array(), np.asarray(velocity, dtype=float)
        if len(self._plan) == 0:
            return LocalResult((0.0, 0.0, 0.0), False, "no plan", np.zeros((0, 3)), 0)
        if self.prune_plan:
            self._prune(p)
        ctx = self._context(ScoringContext(
            p,
            v,
            g,
            float(resolution),
            np.asarray(origin[:2], float),
            np.asarray(footprint, float).reshape(-1, 2),
            self._plan,
            self._plan[-1],
        ))
        local = self._local_plan(ctx)
        if len(local) == 0:
            return LocalResult(
                self._brake(v), False, "the plan is not on the local costmap", np.zeros((0, 3)), 0
            )
        ctx.plan, ctx.goal = local, local[-1]
        goal = self._plan[-1]
        dist = math.hypot(goal[0] - p[0], goal[1] - p[1])
        if dist <= self.limits.xy_goal_tolerance and self.limits.latch_xy_goal_tolerance:
            self._latched = True
        rotating = self._rot_dir != 0.0 and (
            abs(angle_diff(goal[2], p[2])) > self.limits.yaw_goal_tolerance or abs(v[2]) > self.limits.rot_stopped_vel
        )
        if self._latched or dist <= self.limits.xy_goal_tolerance or (
            rotating and dist <= self.limits.xy_goal_tolerance + ROTATION_HOLD_M
        ):
            return self._approach_goal(ctx, goal)
        if self.limits.cut_off_plan_min_reach > 0:
            short = reachable_plan(ctx, self.limits.cut_off_plan_min_reach)
            if short is not None:
                ctx.set_plan(short)
        return self._choose(ctx)

    # --- hooks -----------------------------------------------------------------------------------------
    def _context(self, ctx: ScoringContext) -> ScoringContext:
        """Adjust the scoring context of this cycle (e.g. mark the footprint cells for the flood fills)."""
        return ctx

    def _choose(self, ctx: ScoringContext) -> LocalResult:
        """Sample, simulate and score; the cheapest valid trajectory wins (SimpleScoredSamplingPlanner)."""
        trajs = self._simulate(ctx.pose, ctx.vel, self._samples(ctx.vel))
        res = self.scorer.score(trajs, ctx)
        if res.best < 0:
            return LocalResult(self._brake(ctx.vel), False, res.reason + goal_cut_off(ctx, res.rejected_by),
                               np.zeros((0, 3)), len(trajs))
        cmd = trajs.vels[res.best]
        self.oscillation.update(cmd, ctx.pose)
        return LocalResult(velocity3(cmd), True, "", trajs.row(res.best), len(trajs))

    def _samples(self, vel: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _simulate(self, pose: np.ndarray, vel: np.ndarray, samples: np.ndarray) -> Trajectories:
        raise NotImplementedError

    # --- shared pieces ---------------------------------------------------------------------------------
    def _prune(self, p: np.ndarray) -> None:
        """Drop the plan poses before the one nearest the robot (base_local_planner prunePlan)."""
        if len(self._plan) > 1:
            d = np.hypot(self._plan[:, 0] - p[0], self._plan[:, 1] - p[1])
            self._plan = self._plan[int(np.argmin(d)) :]

    @staticmethod
    def _local_plan(ctx: ScoringContext) -> np.ndarray:
        """The plan from its start up to where it first leaves the local costmap."""
        _, _, inside = ctx.cells(ctx.plan[:, :2])
        if not inside.any():
            return ctx.plan[:0]
        first = int(np.argmax(inside))
        out = np.flatnonzero(~inside[first:])
        end = first + (int(out[0]) if out.size else len(inside) - first)
        return ctx.plan[first:end]

    def _brake(self, v: np.ndarray) -> tuple[float, float, float]:
        """One cycle of deceleration toward zero at the acceleration limits."""
        a, dt = self.limits.acc, self.limits.sim_period
        return velocity3([_toward(float(v[i]), 0.0, a[i] * dt) for i in range(3)])

    def _approach_goal(self, ctx: ScoringContext, goal: np.ndarray) -> LocalResult:
        """Inside the xy tolerance: brake, then rotate in place to the goal yaw without ever reversing.

        The rotation direction is latched when the rotation starts; the speed follows a stopping profile
        so the robot comes to rest at the goal yaw. Only if a disturbance carries it past the tolerance
        band on the other side, it first stops and then turns back (a new latch).
        """
        lim, v = self.limits, ctx.vel
        err = angle_diff(goal[2], ctx.pose[2])
        empty = np.zeros((0, 3))
        a, dt = lim.acc, lim.sim_period
        vx, vy = _toward(float(v[0]), 0.0, a[0] * dt), _toward(float(v[1]), 0.0, a[1] * dt)
        if math.hypot(v[0], v[1]) > lim.trans_stopped_vel:
            return LocalResult(
                (vx, vy, _toward(float(v[2]), 0.0, a[2] * dt)), True, "braking at the goal", empty, 0, True
            )
        inside = abs(err) <= lim.yaw_goal_tolerance
        if not self._rot_dir or (
            err * self._rot_dir < -lim.yaw_goal_tolerance and abs(v[2]) <= lim.rot_stopped_vel
        ):
            self._rot_dir = 0.0 if inside else math.copysign(1.0, err)
            self._rot_cmd = 0.0
        if not self._rot_dir:
            w = 0.0
        else:
            # The measured speed lags the command by about a cycle; the base follows the command, so the
            # profile continues from the last command (else it brakes too late and turns back).
            cur = float(v[2]) * self._rot_dir
            cur = max(cur, self._rot_cmd) if self._rot_cmd > 0.0 else cur
            w = self._rotation_speed(err * self._rot_dir, cur, inside, self._rot_cmd) * self._rot_dir
        self._rot_cmd = w * self._rot_dir if self._rot_dir else 0.0
        if w == 0.0:
            return LocalResult((vx, vy, 0.0), True, "", empty, 0, True)
        cx = lim.rotation_center_x
        trajs = simulate(ctx.pose, driven(v, cx), driven(np.array([[0.0, 0.0, w]]), cx), lim.sim_period * 2, 4)
        self.collision.prepare(ctx)
        if self.collision.score(trajs)[0] < 0:
            return LocalResult(
                self._brake(v), False, "rotation to the goal yaw would collide", empty, 1, True
            )
        return LocalResult((vx, vy, w), True, "", trajs.poses[0], 1, True)

    def _rotation_speed(self, remaining: float, current: float, inside: bool, last_cmd: float | None = None
                        ) -> float:
        """Non-negative rotation speed toward the goal yaw; ``remaining`` and ``current`` are signed
        along the latched direction (negative remaining = already past the goal yaw).

        Proportional to the remaining angle, never above what still allows stopping at the goal yaw
        (sqrt(2 * acc * remaining)) or passing it within one cycle; ``min_in_place_vth`` is a floor only
        where that stopping profile allows it; inside the tolerance the robot only slows down. Limited
        to one cycle of acceleration from the current speed.
        """
        lim, dt = self.limits, self.limits.sim_period
        acc = lim.acc[2]
        if remaining <= 0.0:
            target = 0.0
        else:
            # The command takes effect about one cycle late (the pose is a cycle old by the time the base
            # gets it), and the base turns at its current speed meanwhile: budget that angle before the
            # braking profile, else the robot overshoots the tolerance band and must turn back. Three
            # cycles are budgeted: on a loaded machine a late cycle keeps the last command for longer
            # (seen: one, then two cycles were not enough with the simulator at 2x real time).
            budget = max(remaining - LAG_CYCLES * max(current, 0.0) * dt, 0.0)
            stop_cap = min(math.sqrt(2.0 * acc * budget), (budget + 0.5 * lim.yaw_goal_tolerance) / dt)
            target = min(remaining / max(4 * dt, 1e-3), lim.max_in_place_vth, stop_cap)
            target = max(target, min(lim.min_in_place_vth, stop_cap))
            if inside:
                target = min(target, max(current, 0.0)) if current > lim.rot_stopped_vel else 0.0
        ref = current if last_cmd is None or last_cmd <= 0.0 else last_cmd  # acceleration from the command
        speed = min(max(target, ref - acc * dt), ref + acc * dt)
        return max(speed, 0.0)
