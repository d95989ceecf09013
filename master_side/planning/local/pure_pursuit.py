"""zenav's regulated pure pursuit (``base_local_planner: zenav/RegulatedPurePursuit``), not a ROS 1 planner.

It follows the global plan instead of scoring rollouts against it, which is what clutter needs: the
global plan (navfn on the inflated costmap, replanned several times a second) already threads the
gaps; the controller's job is to track it quickly without touching anything. Per cycle:

1. carrot: the plan point ``lookahead`` ahead along the plan (lookahead = speed x ``lookahead_time``,
   within [``min_lookahead_dist``, ``max_lookahead_dist``]); the arc to it has curvature 2 y / L².
2. far off the plan's heading (> ``rotate_to_heading_min_angle``): turn in place toward it first.
3. speed: ``desired_linear_vel``, reduced on tight curves (radius below
   ``regulated_linear_scaling_min_radius``), near obstacles (clearance of the robot below
   ``cost_scaling_dist``) and near the goal, never below ``regulated_linear_scaling_min_speed``, within
   the acceleration limits.
4. the arc is simulated for ``max_allowed_time_to_collision_up_to_carrot`` (at least the stopping
   time) and checked with the footprint against the costmap (outline off LETHAL, centre off
   INSCRIBED, as ROS's footprint check); if it would collide, slower speeds are tried, then a fan of
   slower arcs (the safe one ending nearest the carrot), then turning in place toward the carrot, then
   backing up straight at ``escape_vel`` for ``escape_dist`` (wedged
   in a corner it cut); else the cycle fails and move_base replans / recovers.

Parameter names follow nav2's RegulatedPurePursuitController where one exists.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from common.config import param
from master_side.planning.grid import LETHAL
from master_side.planning.local.base import Limits, LocalPlanner, LocalResult
from master_side.planning.local.costs import ObstacleCost
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.scoring_context import ScoringContext
from master_side.planning.local.trajectories import simulate


@dataclass(frozen=True)
class PurePursuitParams:
    desired_linear_vel: float = param(1.2, lo=0.01, hi=10.0, unit="m/s")
    max_angular_vel: float = param(2.0, lo=0.1, hi=20.0, unit="rad/s", aliases=("rotate_to_heading_angular_vel",))
    lookahead_time: float = param(0.8, lo=0.05, hi=10.0, unit="s")
    min_lookahead_dist: float = param(0.35, lo=0.01, hi=10.0, unit="m")
    max_lookahead_dist: float = param(1.5, lo=0.05, hi=20.0, unit="m")
    use_rotate_to_heading: bool = param(True)
    rotate_to_heading_min_angle: float = param(0.9, lo=0.0, hi=math.pi, unit="rad")
    regulated_linear_scaling_min_radius: float = param(0.9, lo=0.0, hi=100.0, unit="m")
    regulated_linear_scaling_min_speed: float = param(0.2, lo=0.0, hi=10.0, unit="m/s")
    use_cost_regulated_linear_velocity_scaling: bool = param(True)
    cost_scaling_dist: float = param(0.6, lo=0.0, hi=10.0, unit="m", doc="slow down when obstacles are closer")
    cost_scaling_gain: float = param(1.0, lo=0.0, hi=10.0)
    approach_velocity_scaling_dist: float = param(0.6, lo=0.0, hi=10.0, unit="m")
    max_allowed_time_to_collision_up_to_carrot: float = param(1.0, lo=0.1, hi=10.0, unit="s")
    acc_lim_x: float = param(2.5, lo=0.01, hi=100.0, unit="m/s^2")
    acc_lim_theta: float = param(6.0, lo=0.01, hi=100.0, unit="rad/s^2", aliases=("acc_lim_th",))
    min_in_place_vel_theta: float = param(0.3, lo=0.0, hi=20.0, unit="rad/s")
    escape_vel: float = param(-0.15, lo=-2.0, hi=0.0, unit="m/s", doc="backing-up speed when wedged; 0 = never")
    escape_dist: float = param(0.25, lo=0.0, hi=5.0, unit="m", doc="how far to back up before trying again")
    xy_goal_tolerance: float = param(0.25, lo=0.0, hi=10.0, unit="m")
    yaw_goal_tolerance: float = param(0.15, lo=0.0, hi=3.2, unit="rad")
    latch_xy_goal_tolerance: bool = param(False)
    prune_plan: bool = param(True)
    controller_frequency: float = param(20.0, lo=0.1, hi=1000.0, unit="Hz", doc="move_base's, sets sim_period")

    def limits(self) -> Limits:
        return Limits(
            vx=(0.0, self.desired_linear_vel), vy=(0.0, 0.0), vth=(-self.max_angular_vel, self.max_angular_vel),
            min_in_place_vth=self.min_in_place_vel_theta, max_in_place_vth=self.max_angular_vel,
            max_trans_vel=self.desired_linear_vel, min_trans_vel=0.0,
            acc=(self.acc_lim_x, 0.0, self.acc_lim_theta), sim_period=1.0 / self.controller_frequency,
            xy_goal_tolerance=self.xy_goal_tolerance, yaw_goal_tolerance=self.yaw_goal_tolerance,
            latch_xy_goal_tolerance=self.latch_xy_goal_tolerance)


class _NoOscillation:
    def reset(self) -> None:
        pass


class RegulatedPurePursuit(LocalPlanner):
    def __init__(self, params: PurePursuitParams | None = None):
        self.params = p = params or PurePursuitParams()
        super().__init__(p.limits(), ScoredSamplingPlanner([]), _NoOscillation(), p.prune_plan)
        self.checker = ObstacleCost()
        self._clear_key: tuple | None = None
        self._clear: np.ndarray | None = None
        self._escape_from: np.ndarray | None = None  # where backing up started

    # -- helpers -------------------------------------------------------------------------------------
    def _clearance(self, ctx: ScoringContext) -> float:
        """Distance (m) from the robot centre to the nearest LETHAL cell (EDT cached per costmap)."""
        key = (id(ctx.grid), ctx.grid.shape, float(ctx.origin[0]), float(ctx.origin[1]))
        if key != self._clear_key:
            lethal = ctx.grid >= LETHAL
            self._clear = ndimage.distance_transform_edt(~lethal) * ctx.resolution if lethal.any() else None
            self._clear_key = key
        if self._clear is None:
            return math.inf
        r, c, inside = ctx.cells(ctx.pose[None, :2])
        return float(self._clear[r[0], c[0]]) if inside[0] else 0.0

    def _carrot(self, ctx: ScoringContext, lookahead: float) -> np.ndarray:
        """The first plan point at least ``lookahead`` from the robot (else the local plan's end)."""
        d = np.hypot(ctx.plan[:, 0] - ctx.pose[0], ctx.plan[:, 1] - ctx.pose[1])
        far = np.flatnonzero(d >= lookahead)
        return ctx.plan[far[0]] if far.size else ctx.plan[-1]

    def _safe(self, ctx: ScoringContext, cmds: np.ndarray, horizon: float) -> np.ndarray:
        """Which (v, 0, w) commands can be held for ``horizon`` s without a collision."""
        reach = horizon * max(float(np.abs(cmds[:, 0]).max()), 0.2, 0.4 * float(np.abs(cmds[:, 2]).max()))
        trajs = simulate(ctx.pose, ctx.vel, cmds, horizon, max(2, int(math.ceil(reach / (0.25 * ctx.resolution)))))
        self.checker.prepare(ctx)
        return self.checker.score(trajs) >= 0

    # -- the cycle -----------------------------------------------------------------------------------
    def _choose(self, ctx: ScoringContext) -> LocalResult:
        p, pose, vel = self.params, ctx.pose, ctx.vel
        dt = self.limits.sim_period
        if self._escape_from is not None:
            if math.hypot(*(pose[:2] - self._escape_from[:2])) < p.escape_dist:
                out = self._back_up(ctx, "backing up out of a corner")
                if out.ok:
                    return out
            self._escape_from = None
        speed = max(float(vel[0]), 0.0)
        lookahead = min(max(speed * p.lookahead_time, p.min_lookahead_dist), p.max_lookahead_dist)
        carrot = self._carrot(ctx, lookahead)
        dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        x_r, y_r = c * dx + s * dy, -s * dx + c * dy
        dist = math.hypot(x_r, y_r)
        heading_err = math.atan2(y_r, x_r)
        if p.use_rotate_to_heading and abs(heading_err) > p.rotate_to_heading_min_angle:
            return self._rotate(ctx, heading_err, "turning toward the plan")
        curvature = 2.0 * y_r / max(dist * dist, 1e-6)
        v = p.desired_linear_vel
        if abs(curvature) > 1e-6 and 1.0 / abs(curvature) < p.regulated_linear_scaling_min_radius:
            v *= (1.0 / abs(curvature)) / p.regulated_linear_scaling_min_radius
        if p.use_cost_regulated_linear_velocity_scaling and p.cost_scaling_dist > 0:
            clear = self._clearance(ctx)
            if clear < p.cost_scaling_dist:
                v *= max(clear / p.cost_scaling_dist, 0.0) ** p.cost_scaling_gain
        to_goal = math.hypot(*(self._plan[-1, :2] - pose[:2]))
        if p.approach_velocity_scaling_dist > 0 and to_goal < p.approach_velocity_scaling_dist:
            v *= to_goal / p.approach_velocity_scaling_dist
        v = max(v, min(p.regulated_linear_scaling_min_speed, p.desired_linear_vel))
        v = min(v, speed + p.acc_lim_x * dt)
        v = max(v, speed - p.acc_lim_x * dt, 0.0)
        horizon = max(p.max_allowed_time_to_collision_up_to_carrot, v / p.acc_lim_x)
        speeds = np.array([v, 0.75 * v, 0.5 * v, 0.25 * v])
        speeds = speeds[speeds >= 0.02]
        w = np.clip(speeds * curvature, -p.max_angular_vel, p.max_angular_vel)
        cmds = np.column_stack((speeds, np.zeros_like(speeds), w))
        ok = self._safe(ctx, cmds, horizon) if len(cmds) else np.zeros(0, bool)
        if ok.any():
            i = int(np.argmax(ok))
            traj = simulate(pose, vel, cmds[i:i + 1], horizon, 10).poses[0]
            return LocalResult((float(cmds[i, 0]), 0.0, float(cmds[i, 2])), True, "", traj, len(cmds))
        fan = self._fan(ctx, carrot, horizon)
        if fan is not None:
            return fan
        return self._rotate(ctx, heading_err, "the arc to the plan would collide")

    def _fan(self, ctx: ScoringContext, carrot: np.ndarray, horizon: float) -> LocalResult | None:
        """Slow arcs around the blocked one: the collision-free arc whose end is nearest the carrot."""
        p = self.params
        v_lo = min(p.regulated_linear_scaling_min_speed, p.desired_linear_vel)
        vs, ws = np.meshgrid(np.linspace(v_lo / 2, 2 * v_lo, 4), np.linspace(-p.max_angular_vel, p.max_angular_vel, 15))
        cmds = np.column_stack((vs.ravel(), np.zeros(vs.size), ws.ravel()))
        ok = self._safe(ctx, cmds, horizon)
        if not ok.any():
            return None
        trajs = simulate(ctx.pose, ctx.vel, cmds[ok], horizon, 10)
        end = trajs.poses[:, -1, :2]
        i = int(np.argmin(np.hypot(end[:, 0] - carrot[0], end[:, 1] - carrot[1])))
        c = trajs.vels[i]
        return LocalResult((float(c[0]), 0.0, float(c[2])), True, "", trajs.poses[i], len(cmds))

    def _rotate(self, ctx: ScoringContext, err: float, why: str) -> LocalResult:
        p, dt = self.params, self.limits.sim_period
        w_now = float(ctx.vel[2])
        target = math.copysign(min(p.max_angular_vel, max(p.min_in_place_vel_theta,
                                                          math.sqrt(2 * p.acc_lim_theta * abs(err)))), err)
        w = min(max(target, w_now - p.acc_lim_theta * dt), w_now + p.acc_lim_theta * dt)
        if abs(w) < p.min_in_place_vel_theta:
            w = math.copysign(p.min_in_place_vel_theta, err)
        cmd = np.array([[0.0, 0.0, w]])
        if self._safe(ctx, cmd, min(0.5, abs(err) / max(abs(w), 1e-3)))[0]:
            traj = simulate(ctx.pose, ctx.vel, cmd, 0.5, 5).poses[0]
            return LocalResult((0.0, 0.0, float(w)), True, "", traj, 1)
        reason = f"{why}; turning in place would collide too"
        if self.params.escape_vel < 0.0 and self._escape_from is None:
            out = self._back_up(ctx, f"{reason}: backing up")
            if out.ok:
                self._escape_from = ctx.pose.copy()
                return out
            reason += ", and so would backing up"  # the stop says why no escape was tried further
        return LocalResult(self._brake(ctx.vel), False, reason, np.zeros((0, 3)), 1)

    def _back_up(self, ctx: ScoringContext, why: str) -> LocalResult:
        """Straight back over escape_dist (long enough to leave a contact the padded footprint is in)."""
        p = self.params
        cmd = np.array([[p.escape_vel, 0.0, 0.0]])
        horizon = max(0.5, p.escape_dist / abs(p.escape_vel))
        if self._safe(ctx, cmd, horizon)[0]:
            traj = simulate(ctx.pose, ctx.vel, cmd, horizon, 10).poses[0]
            return LocalResult((float(cmd[0, 0]), 0.0, 0.0), True, why, traj, 1)
        return LocalResult(self._brake(ctx.vel), False, f"{why}: backing up would collide", np.zeros((0, 3)), 1)
