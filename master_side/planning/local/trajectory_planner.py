"""Trajectory rollout (base_local_planner/TrajectoryPlannerROS), as ROS's TrajectoryPlanner does it.

One cycle (createTrajectories): forward samples over the window reachable within ``sim_time`` (or one
control period with ``dwa: true``), each with vtheta 0 first and then the rotation samples; then, unless
something forward is cheaper, an in-place rotation chosen by ``heading_lookahead`` (the rotation whose
end pose looks at the point with the smallest goal distance), never in the direction the oscillation
flags forbid; if nothing is valid, back up at ``escape_vel``. Each trajectory costs
``path_distance_bias * path + goal_distance_bias * goal + occdist_scale * footprint cost`` with path / goal
the MapGrid flood-fill distances in cells (``meter_scoring``: metres), or ``heading_scoring`` /
``simple_attractor`` as in ROS. Defaults are the effective ROS ones (BaseLocalPlanner.cfg, whose
dynamic-reconfigure values override the node's own param() defaults).

Deliberate differences (see the README): after a full revolution of in-place turning without the
robot moving ``oscillation_reset_dist``, in-place rotations are left out until it has moved one
circumscribed radius (ROS keeps spinning whenever turning scores better than entering a tight gap,
which with a large ``occdist_scale`` is always); the escape (backing up) is only taken when the
backward trajectory is collision-free, for the robot's own outline when the padded footprint is
already wedged (ROS backs up even into an obstacle); ``acc_lim_th`` is read as ``acc_lim_theta``
(ROS's TrajectoryPlannerROS ignores it); the goal approach (brake, rotate to the goal yaw) is zenav's
shared profile (``base.LocalPlanner``), which never reverses the final rotation.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.geometry import TurnCounter, footprint_radii
from master_side.costmap.footprint import pad_footprint
from master_side.planning.local.base import Limits, LocalPlanner, LocalResult, velocity3
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.scoring_context import ScoringContext, angle_diff
from master_side.planning.local.trajectories import Trajectories, ros_steps, simulate_ramped
from master_side.planning.local.trajectory_cost import TPOscillation, TrajectoryCost


@dataclass(frozen=True)
class TrajectoryPlannerParams:
    max_vel_x: float = param(0.55, lo=0.0, hi=20.0, unit="m/s")
    min_vel_x: float = param(0.0, lo=0.0, hi=20.0, unit="m/s")
    max_vel_theta: float = param(1.0, lo=0.0, hi=20.0, unit="rad/s")
    min_vel_theta: float = param(-1.0, lo=-20.0, hi=0.0, unit="rad/s")
    max_rotational_vel: float = param(1.0, lo=0.0, hi=20.0, unit="rad/s",
                                      doc="rotation limit of the goal approach (ROS reads it separately)")
    min_in_place_vel_theta: float = param(0.4, lo=0.0, hi=20.0, unit="rad/s",
                                          aliases=("min_in_place_rotational_vel",))
    escape_vel: float = param(-0.1, lo=-10.0, hi=0.0, unit="m/s", aliases=("backup_vel",),
                              doc="negative: back up when stuck")
    acc_lim_x: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_y: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_theta: float = param(3.2, lo=0.0, hi=100.0, unit="rad/s^2", aliases=("acc_lim_th",))
    holonomic_robot: bool = param(True)
    y_vels: tuple[float, ...] | str = param((-0.3, -0.1, 0.1, 0.3), unit="m/s", doc="strafe samples (holonomic)")
    sim_time: float = param(1.7, lo=0.05, hi=20.0, unit="s")
    sim_granularity: float = param(0.025, lo=0.001, hi=5.0, unit="m")
    angular_sim_granularity: float = param(0.025, lo=0.001, hi=3.2, unit="rad")
    vx_samples: int = param(20, lo=1, hi=300)
    vtheta_samples: int = param(20, lo=1, hi=300, aliases=("vth_samples",))
    path_distance_bias: float = param(0.6, lo=0.0, hi=1000.0, aliases=("pdist_scale",))
    goal_distance_bias: float = param(0.8, lo=0.0, hi=1000.0, aliases=("gdist_scale",))
    occdist_scale: float = param(0.01, lo=0.0, hi=1000.0)
    dwa: bool = param(False, doc="true: window of one control period (the velocity still ramps)")
    meter_scoring: bool = param(False, doc="path / goal distances in metres (true) or cells (false)")
    heading_lookahead: float = param(0.325, lo=0.0, hi=10.0, unit="m",
                                     doc="look-ahead that picks among in-place rotations")
    heading_scoring: bool = param(False, doc="score the heading to the plan at heading_scoring_timestep")
    heading_scoring_timestep: float = param(0.1, lo=0.0, hi=10.0, unit="s")
    simple_attractor: bool = param(False, doc="score squared distance to the goal only (no flood fill)")
    oscillation_reset_dist: float = param(0.05, lo=0.0, hi=10.0, unit="m")
    escape_reset_dist: float = param(0.10, lo=0.0, hi=10.0, unit="m")
    escape_reset_theta: float = param(math.pi / 2, lo=0.0, hi=6.3, unit="rad")
    prune_plan: bool = param(True)
    xy_goal_tolerance: float = param(0.10, lo=0.0, hi=10.0, unit="m")
    yaw_goal_tolerance: float = param(0.05, lo=0.0, hi=3.2, unit="rad")
    latch_xy_goal_tolerance: bool = param(False)
    controller_frequency: float = param(20.0, lo=0.1, hi=1000.0, unit="Hz", doc="move_base's, sets sim_period")

    def __post_init__(self):
        if isinstance(self.y_vels, str):  # ROS gives y_vels as a string "-0.3,-0.1,0.1,0.3"
            try:
                vals = tuple(float(v) for v in self.y_vels.replace("[", " ").replace("]", " ")
                             .replace(",", " ").split())
            except ValueError as e:
                raise ValueError(f"y_vels: expected numbers, got {self.y_vels!r}") from e
            object.__setattr__(self, "y_vels", vals)

    def validate(self) -> None:
        if self.min_vel_x > self.max_vel_x:
            raise ValueError(f"min_vel_x {self.min_vel_x} > max_vel_x {self.max_vel_x}")
        if self.min_in_place_vel_theta > self.max_vel_theta:
            raise ValueError(f"min_in_place_vel_theta {self.min_in_place_vel_theta} > max_vel_theta")

    def limits(self) -> Limits:
        return Limits(
            vx=(self.min_vel_x, self.max_vel_x), vy=(0.0, 0.0), vth=(self.min_vel_theta, self.max_vel_theta),
            min_in_place_vth=self.min_in_place_vel_theta, max_in_place_vth=self.max_rotational_vel,
            max_trans_vel=max(self.max_vel_x, abs(self.escape_vel)), min_trans_vel=0.0,
            acc=(self.acc_lim_x, self.acc_lim_y, self.acc_lim_theta), sim_period=1.0 / self.controller_frequency,
            xy_goal_tolerance=self.xy_goal_tolerance, yaw_goal_tolerance=self.yaw_goal_tolerance,
            latch_xy_goal_tolerance=self.latch_xy_goal_tolerance)


def _window_samples(lo: float, hi: float, n: int) -> tuple[np.ndarray, float]:
    """ROS's sampling: lo, lo + d, ... with d = (hi - lo) / (n - 1); (samples, d)."""
    d = (hi - lo) / (n - 1) if n > 1 else 0.0
    return lo + d * np.arange(n), d


class TrajectoryPlanner(LocalPlanner):
    def __init__(self, params: TrajectoryPlannerParams | None = None):
        p = params or TrajectoryPlannerParams()
        self.params = p
        self.cost = TrajectoryCost(p)
        self.flags = TPOscillation(p.oscillation_reset_dist)
        super().__init__(p.limits(), ScoredSamplingPlanner([]), self.flags, p.prune_plan)
        self._escape: np.ndarray | None = None  # pose where the escape started
        self._spin = TurnCounter()  # in-place turning since the robot last moved oscillation_reset_dist
        self._spin_from: np.ndarray | None = None  # (x, y) where that turning started
        self._no_spin_from: np.ndarray | None = None  # where in-place rotation was left out

    def _context(self, ctx: ScoringContext) -> ScoringContext:
        ctx.within_robot = True  # TrajectoryPlanner::findBestPath marks the footprint cells
        return ctx

    def _choose(self, ctx: ScoringContext) -> LocalResult:
        p, pose, vel = self.params, ctx.pose, ctx.vel
        t = self.limits.sim_period if p.dwa else p.sim_time
        vmax = p.max_vel_x
        if len(self._plan):  # slow down toward the plan's end (final_goal_dist / sim_time)
            vmax = min(vmax, math.hypot(*(self._plan[-1, :2] - pose[:2])) / p.sim_time)
        vx_hi = max(min(vmax, vel[0] + p.acc_lim_x * t), p.min_vel_x)
        vx_lo = max(p.min_vel_x, vel[0] - p.acc_lim_x * t)
        th_hi = min(p.max_vel_theta, vel[2] + p.acc_lim_theta * t)
        th_lo = max(p.min_vel_theta, vel[2] - p.acc_lim_theta * t)
        vxs, _ = _window_samples(vx_lo, vx_hi, p.vx_samples)
        ths, dth = _window_samples(th_lo, th_hi, p.vtheta_samples)
        escaping = self._escape is not None
        fwd = []
        if not escaping:
            for vx in vxs:  # ROS order: vtheta 0 first, then min .. (the last sample is never max)
                fwd.append((vx, 0.0, 0.0))
                fwd.extend((vx, 0.0, th) for th in ths[:-1] if p.vtheta_samples > 1)
            if p.holonomic_robot:
                fwd += [(0.1, 0.1, 0.0), (0.1, -0.1, 0.0)]
        spun = self._spun(pose, ctx.footprint)
        rot = [] if spun else [(0.0, 0.0, max(th, p.min_in_place_vel_theta) if th > 0
                                else min(th, -p.min_in_place_vel_theta)) for th in ths]
        samples = np.array(fwd + rot, float).reshape(-1, 3)
        trajs = self._rollout(pose, vel, samples)
        costs = self.cost.score(trajs, ctx)
        best = -1
        for i in range(len(fwd)):  # strictly better wins: the first of equals stays
            if costs[i] >= 0 and (best < 0 or costs[i] < costs[best]):
                best = i
        heading = math.inf
        ahead = self.cost.lookahead_goal_distance(trajs, ctx, p.heading_lookahead)
        for k, th in enumerate(ths[:len(rot)]):
            i = len(fwd) + k
            better = best < 0 or costs[i] <= costs[best] or samples[best, 1] != 0.0
            if costs[i] < 0 or not better or not (th > dth or th < -dth) or not ahead[i] < heading:
                continue
            if (th < 0 and not self.flags.stuck_left) or (th > 0 and not self.flags.stuck_right):
                best, heading = i, ahead[i]
        if best < 0 and p.holonomic_robot:
            strafe = np.array([(0.0, vy, 0.0) for vy in p.y_vels], float).reshape(-1, 3)
            if len(strafe):
                st = self._rollout(pose, vel, strafe)
                sc, sa = self.cost.score(st, ctx), self.cost.lookahead_goal_distance(st, ctx, p.heading_lookahead)
                for i, vy in enumerate(strafe[:, 1]):
                    if sc[i] >= 0 and sa[i] < heading and ((vy > 0 and not self.flags.stuck_left_strafe)
                                                          or (vy < 0 and not self.flags.stuck_right_strafe)):
                        trajs, samples, costs, best, heading = st, strafe, sc, i, sa[i]
        if best >= 0:
            cmd = samples[best]
            self.flags.chose(cmd, pose)
            self._end_escape(pose)
            return LocalResult(velocity3(cmd), True, "", trajs.poses[best], len(samples))
        return self._back_up(ctx, len(samples))

    def _spun(self, pose: np.ndarray, footprint: np.ndarray) -> bool:
        """Leave in-place rotations out? Yes from a full revolution of in-place turning without moving
        oscillation_reset_dist, until the robot has moved one circumscribed radius from there."""
        reset = self.params.oscillation_reset_dist
        if self._no_spin_from is not None:
            if math.hypot(*(pose[:2] - self._no_spin_from[:2])) <= max(reset, footprint_radii(footprint)[1]):
                return True
            self._no_spin_from = None
        start = self._spin_from
        if start is None or math.hypot(*(pose[:2] - start[:2])) > reset:
            self._spin.reset()
            self._spin.add(pose[2])
            self._spin_from = pose[:2].copy()
            return False
        if self._spin.add(pose[2]) < 2 * math.pi:
            return False
        self._spin.reset()
        self._spin_from, self._no_spin_from = None, pose.copy()
        return True

    def _rollout(self, pose: np.ndarray, vel: np.ndarray, samples: np.ndarray) -> Trajectories:
        p = self.params
        steps = ros_steps(samples, p.sim_time, p.sim_granularity, p.angular_sim_granularity, p.heading_scoring)
        acc = np.array([p.acc_lim_x, p.acc_lim_y, p.acc_lim_theta])
        trajs, _ = simulate_ramped(pose, vel, samples, p.sim_time, steps, acc)
        return trajs

    def _back_up(self, ctx: ScoringContext, n: int) -> LocalResult:
        """Nothing valid: back up at escape_vel (ROS's escape). ROS backs up even into an obstacle; zenav
        backs up when the backward trajectory is free for the footprint, or, wedged with the padded
        footprint already touching something, free for the robot's own outline (``footprint_padding``
        taken off again); otherwise the cycle fails and move_base's patience decides."""
        p, pose = self.params, ctx.pose
        reason = self.cost.reason or "every trajectory was rejected"
        self.flags.moved(pose)
        if p.escape_vel < 0.0:
            back = self._rollout(pose, ctx.vel, np.array([[p.escape_vel, 0.0, 0.0]]))
            free = self.cost.collision_free(back, ctx)[0]
            if not free and self.footprint_padding > 0.0:
                bare = dataclasses.replace(ctx, footprint=pad_footprint(ctx.footprint, -self.footprint_padding),
                                           _cache={})
                free = self.cost.collision_free(back, bare)[0]
            if free:
                if self._escape is None:
                    self._escape = pose.copy()
                self._end_escape(pose)
                return LocalResult((p.escape_vel, 0.0, 0.0), True, f"escaping: {reason}", back.poses[0], n + 1)
        self._escape = None  # cannot back up: look forward again next cycle
        return LocalResult(self._brake(ctx.vel), False, reason, np.zeros((0, 3)), n + 1)

    def _end_escape(self, pose: np.ndarray) -> None:
        e = self._escape
        if e is not None and (math.hypot(*(pose[:2] - e[:2])) > self.params.escape_reset_dist
                              or abs(angle_diff(pose[2], e[2])) > self.params.escape_reset_theta):
            self._escape = None

    @property
    def escaping(self) -> bool:
        return self._escape is not None
