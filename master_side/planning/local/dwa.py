"""DWA local planner (dwa_local_planner/DWAPlannerROS): constant-velocity samples from the window
reachable within one control period, scored by path/goal distance, alignment, obstacle and
oscillation costs.

Parameter notes: defaults are dwa_local_planner's. The tutorial's ``dwa_planner_ros.yaml`` sets
``min_vel_x: -0.55`` and no ``max_vel_x`` (its line was lost): it loads as written, so max_vel_x keeps
the ROS default 0.55 and the robot may back up (reverse samples are scored like any other and only
win when nothing forward is acceptable, since the alignment costs favour facing along the path).
``holonomic_robot`` is not a DWA parameter in ROS; here false forces vy = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.config import param
from master_side.planning.local.base import Limits, LocalPlanner, driven
from master_side.planning.local.costs import (
    GoalAlign,
    GoalDistance,
    ObstacleCost,
    Oscillation,
    PathAlign,
    PathDistance,
    Twirling,
)
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.trajectories import (
    Trajectories,
    linspace_window,
    num_steps,
    sample_grid,
    simulate,
)


@dataclass(frozen=True)
class DWAPlannerParams:
    acc_lim_x: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_y: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_th: float = param(3.2, lo=0.0, hi=100.0, unit="rad/s^2", aliases=("acc_lim_theta",))
    max_vel_x: float = param(0.55, lo=-10.0, hi=10.0, unit="m/s")
    min_vel_x: float = param(0.0, lo=-10.0, hi=10.0, unit="m/s", doc="negative allows reversing")
    max_vel_y: float = param(0.1, lo=-10.0, hi=10.0, unit="m/s")
    min_vel_y: float = param(-0.1, lo=-10.0, hi=10.0, unit="m/s")
    max_trans_vel: float = param(0.55, lo=0.0, hi=10.0, unit="m/s", aliases=("max_vel_trans",))
    min_trans_vel: float = param(0.1, lo=0.0, hi=10.0, unit="m/s", aliases=("min_vel_trans",))
    max_rot_vel: float = param(1.0, lo=0.0, hi=20.0, unit="rad/s", aliases=("max_vel_theta",))
    min_rot_vel: float = param(0.4, lo=0.0, hi=20.0, unit="rad/s", aliases=("min_vel_theta",))
    sim_time: float = param(1.7, lo=0.05, hi=20.0, unit="s")
    sim_granularity: float = param(0.025, lo=0.001, hi=1.0, unit="m")
    angular_sim_granularity: float = param(0.1, lo=0.001, hi=3.2, unit="rad")
    vx_samples: int = param(3, lo=1, hi=200)
    vy_samples: int = param(10, lo=1, hi=200)
    vth_samples: int = param(20, lo=1, hi=400, aliases=("vtheta_samples",))
    path_distance_bias: float = param(32.0, lo=0.0, hi=1000.0)
    goal_distance_bias: float = param(24.0, lo=0.0, hi=1000.0)
    occdist_scale: float = param(0.01, lo=0.0, hi=1000.0)
    twirling_scale: float = param(0.0, lo=0.0, hi=1000.0)
    forward_point_distance: float = param(0.325, lo=0.0, hi=10.0, unit="m")
    stop_time_buffer: float = param(0.2, lo=0.0, hi=10.0, unit="s", doc="accepted; not used")
    oscillation_reset_dist: float = param(0.05, lo=0.0, hi=10.0, unit="m")
    oscillation_reset_angle: float = param(0.2, lo=0.0, hi=6.3, unit="rad")
    prune_plan: bool = param(True)
    xy_goal_tolerance: float = param(0.1, lo=0.0, hi=10.0, unit="m")
    yaw_goal_tolerance: float = param(0.05, lo=0.0, hi=3.2, unit="rad")
    latch_xy_goal_tolerance: bool = param(False)
    trans_stopped_vel: float = param(0.1, lo=0.0, hi=10.0, unit="m/s")
    rot_stopped_vel: float = param(0.1, lo=0.0, hi=10.0, unit="rad/s")
    holonomic_robot: bool = param(True, doc="false: vy is always 0")
    rotation_center_x: float = param(
        0.0, lo=-2.0, hi=2.0, unit="m",
        doc="zenav: where on base_link's x axis the base turns about; every trajectory is predicted with "
            "base_link moving sideways at -rotation_center_x * w. 0: a differential "
            "drive (ROS). A skid-steered base pivots toward its more loaded axle: measure it with "
            "`python bench/turning.py`")
    controller_frequency: float = param(
        20.0, lo=0.1, hi=1000.0, unit="Hz", doc="move_base's, sets sim_period"
    )
    cut_off_plan_min_reach: float = param(
        0.0, lo=0.0, hi=100.0, unit="m",
        doc="zenav: when the local costmap cuts the local goal off from the robot, follow the plan to its "
            "farthest pose the robot can reach, if that lies at least this far along it "
            "(master_side/planning/local/reachable.py); 0: ROS's (every trajectory rejected until "
            "controller_patience runs out)")

    def validate(self) -> None:
        if self.min_vel_x > self.max_vel_x:
            raise ValueError(f"min_vel_x {self.min_vel_x} > max_vel_x {self.max_vel_x}")
        if self.min_vel_y > self.max_vel_y:
            raise ValueError(f"min_vel_y {self.min_vel_y} > max_vel_y {self.max_vel_y}")
        if self.min_trans_vel > self.max_trans_vel:
            raise ValueError(f"min_trans_vel {self.min_trans_vel} > max_trans_vel {self.max_trans_vel}")
        if self.min_rot_vel > self.max_rot_vel:
            raise ValueError(f"min_rot_vel {self.min_rot_vel} > max_rot_vel {self.max_rot_vel}")

    def limits(self) -> Limits:
        vy = (self.min_vel_y, self.max_vel_y) if self.holonomic_robot else (0.0, 0.0)
        return Limits(
            vx=(self.min_vel_x, self.max_vel_x),
            vy=vy,
            vth=(-self.max_rot_vel, self.max_rot_vel),
            min_in_place_vth=self.min_rot_vel,
            max_in_place_vth=self.max_rot_vel,
            max_trans_vel=self.max_trans_vel,
            min_trans_vel=self.min_trans_vel,
            acc=(self.acc_lim_x, self.acc_lim_y, self.acc_lim_th),
            sim_period=1.0 / self.controller_frequency,
            xy_goal_tolerance=self.xy_goal_tolerance,
            yaw_goal_tolerance=self.yaw_goal_tolerance,
            latch_xy_goal_tolerance=self.latch_xy_goal_tolerance,
            trans_stopped_vel=self.trans_stopped_vel,
            rot_stopped_vel=self.rot_stopped_vel,
            rotation_center_x=self.rotation_center_x,
            cut_off_plan_min_reach=self.cut_off_plan_min_reach,
        )


class DWAPlanner(LocalPlanner):
    """Costs as ROS noetic's dwa_planner.cpp: oscillation, obstacle (occdist_scale), goal-front and goal
    distance (goal_distance_bias per metre of flood-fill distance), alignment and path distance
    (path_distance_bias per metre), twirling. (Kinetic and older halved the two biases.)"""

    def __init__(self, params: DWAPlannerParams | None = None):
        p = params or DWAPlannerParams()
        self.params = p
        osc = Oscillation(p.oscillation_reset_dist, p.oscillation_reset_angle, min_trans_vel=p.min_trans_vel)
        fpd = p.forward_point_distance
        costs = [
            osc,
            ObstacleCost(p.occdist_scale),
            GoalAlign(p.goal_distance_bias, fpd),
            PathAlign(p.path_distance_bias, fpd),
            PathDistance(p.path_distance_bias),
            GoalDistance(p.goal_distance_bias),
            Twirling(p.twirling_scale),
        ]
        super().__init__(p.limits(), ScoredSamplingPlanner(costs), osc, p.prune_plan)

    def _samples(self, vel: np.ndarray) -> np.ndarray:
        """Grid over the dynamic window v +- acc * sim_period, then the translation/rotation limits.

        Samples slower than both min_trans_vel and min_rot_vel are dropped (as in ROS). Unlike ROS, a
        window edge that stops short of min_trans_vel / min_rot_vel is widened to it: with the p3at file
        (acc_lim_x 1.0, min_trans_vel 0.1, at 20 Hz) ROS DWA has no valid sample from standstill.
        """
        lim, dt = self.limits, self.limits.sim_period
        win = []
        for i, (lo, hi), n in (
            (0, lim.vx, self.params.vx_samples),
            (1, lim.vy, self.params.vy_samples),
            (2, lim.vth, self.params.vth_samples),
        ):
            a = max(lo, min(hi, vel[i] - lim.acc[i] * dt))
            b = min(hi, max(lo, vel[i] + lim.acc[i] * dt))
            floor = lim.min_trans_vel if i < 2 else lim.min_in_place_vth
            if 0.0 < b < floor <= hi:  # see _samples' doc: let a slow-accelerating base start moving
                b = floor
            if lo <= -floor < a < 0.0:  # the same the other way (both ways of turning in place)
                a = -floor
            win.append(linspace_window(a, b, n if hi > lo else 1))
        s = sample_grid(*win)
        trans = np.hypot(s[:, 0], s[:, 1])
        ok = (trans <= lim.max_trans_vel + 1e-9) & ~(
            (trans < lim.min_trans_vel) & (np.abs(s[:, 2]) < lim.min_in_place_vth)
        )
        return s[ok]

    def _simulate(self, pose: np.ndarray, vel: np.ndarray, samples: np.ndarray) -> Trajectories:
        p = self.params
        steps = num_steps(samples, p.sim_time, p.sim_granularity, p.angular_sim_granularity)
        cx = p.rotation_center_x
        trajs = simulate(pose, driven(vel, cx), driven(samples, cx), p.sim_time, steps)
        trajs.vels = samples  # the commands; the poses are where the base goes under them
        return trajs
