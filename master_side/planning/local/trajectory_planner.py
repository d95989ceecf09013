"""Trajectory rollout (base_local_planner/TrajectoryPlannerROS).

Samples over the window reachable within ``sim_time`` (or one control period with ``dwa: true``);
without ``dwa`` the simulated velocity ramps toward the sample at the acceleration limits. Costs:
``pdist_scale * path distance + gdist_scale * goal distance + occdist_scale * obstacle cost``, with
distances in cells unless ``meter_scoring``. In-place rotation samples respect
``min_in_place_vel_theta``. When every sample is rejected the robot backs up at ``escape_vel`` (if that
is collision-free) until it has moved ``escape_reset_dist``. Defaults are base_local_planner's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.config import param
from master_side.planning.local.base import Limits, LocalPlanner, LocalResult
from master_side.planning.local.costs import GoalDistance, ObstacleCost, Oscillation, PathDistance
from master_side.planning.local.map_grid import ScoringContext
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.trajectories import (
    Trajectories,
    linspace_window,
    num_steps,
    sample_grid,
    simulate,
)


@dataclass(frozen=True)
class TrajectoryPlannerParams:
    max_vel_x: float = param(0.5, lo=0.0, hi=10.0, unit="m/s")
    min_vel_x: float = param(0.1, lo=0.0, hi=10.0, unit="m/s")
    max_vel_theta: float = param(1.0, lo=0.0, hi=20.0, unit="rad/s", aliases=("max_rotational_vel",))
    min_vel_theta: float = param(-1.0, lo=-20.0, hi=0.0, unit="rad/s")
    min_in_place_vel_theta: float = param(
        0.4, lo=0.0, hi=20.0, unit="rad/s", aliases=("min_in_place_rotational_vel",)
    )
    escape_vel: float = param(-0.1, lo=-10.0, hi=0.0, unit="m/s", doc="negative: back up when stuck")
    acc_lim_x: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_y: float = param(2.5, lo=0.0, hi=100.0, unit="m/s^2")
    acc_lim_theta: float = param(3.2, lo=0.0, hi=100.0, unit="rad/s^2", aliases=("acc_lim_th",))
    holonomic_robot: bool = param(True)
    y_vels: tuple[float, ...] = param((-0.3, -0.1, 0.1, 0.3), unit="m/s", doc="strafe samples (holonomic)")
    sim_time: float = param(1.0, lo=0.05, hi=20.0, unit="s")
    sim_granularity: float = param(0.025, lo=0.001, hi=1.0, unit="m")
    angular_sim_granularity: float = param(0.025, lo=0.001, hi=3.2, unit="rad")
    vx_samples: int = param(3, lo=1, hi=200)
    vtheta_samples: int = param(20, lo=1, hi=400, aliases=("vth_samples",))
    pdist_scale: float = param(0.6, lo=0.0, hi=1000.0)
    gdist_scale: float = param(0.8, lo=0.0, hi=1000.0)
    occdist_scale: float = param(0.01, lo=0.0, hi=1000.0)
    dwa: bool = param(False, doc="true: window of one control period, constant-velocity simulation")
    meter_scoring: bool = param(False, doc="distances in metres (true) or cells (false)")
    heading_lookahead: float = param(
        0.325, lo=0.0, hi=10.0, unit="m", doc="accepted; heading scoring not used"
    )
    heading_scoring: bool = param(False, doc="accepted; not implemented")
    oscillation_reset_dist: float = param(0.05, lo=0.0, hi=10.0, unit="m")
    escape_reset_dist: float = param(0.10, lo=0.0, hi=10.0, unit="m")
    escape_reset_theta: float = param(math.pi / 4, lo=0.0, hi=6.3, unit="rad", doc="accepted; not used")
    prune_plan: bool = param(True)
    xy_goal_tolerance: float = param(0.10, lo=0.0, hi=10.0, unit="m")
    yaw_goal_tolerance: float = param(0.05, lo=0.0, hi=3.2, unit="rad")
    latch_xy_goal_tolerance: bool = param(False)
    controller_frequency: float = param(
        20.0, lo=0.1, hi=1000.0, unit="Hz", doc="move_base's, sets sim_period"
    )

    def validate(self) -> None:
        if self.min_vel_x > self.max_vel_x:
            raise ValueError(f"min_vel_x {self.min_vel_x} > max_vel_x {self.max_vel_x}")
        if self.min_in_place_vel_theta > self.max_vel_theta:
            raise ValueError(f"min_in_place_vel_theta {self.min_in_place_vel_theta} > max_vel_theta")

    def limits(self) -> Limits:
        return Limits(
            vx=(self.min_vel_x, self.max_vel_x),
            vy=(0.0, 0.0),
            vth=(self.min_vel_theta, self.max_vel_theta),
            min_in_place_vth=self.min_in_place_vel_theta,
            max_in_place_vth=self.max_vel_theta,
            max_trans_vel=max(self.max_vel_x, abs(self.escape_vel)),
            min_trans_vel=0.0,
            acc=(self.acc_lim_x, self.acc_lim_y, self.acc_lim_theta),
            sim_period=1.0 / self.controller_frequency,
            xy_goal_tolerance=self.xy_goal_tolerance,
            yaw_goal_tolerance=self.yaw_goal_tolerance,
            latch_xy_goal_tolerance=self.latch_xy_goal_tolerance,
        )


class TrajectoryPlanner(LocalPlanner):
    def __init__(self, params: TrajectoryPlannerParams | None = None):
        p = params or TrajectoryPlannerParams()
        self.params = p
        osc = Oscillation(p.oscillation_reset_dist, 0.2)
        self._path = PathDistance(p.pdist_scale)
        self._goal = GoalDistance(p.gdist_scale)
        super().__init__(
            p.limits(),
            ScoredSamplingPlanner([osc, ObstacleCost(p.occdist_scale), self._path, self._goal]),
            osc,
            p.prune_plan,
        )
        self._escape_from: np.ndarray | None = None

    def compute_velocity(self, pose, velocity, grid, resolution, origin, footprint) -> LocalResult:
        if not self.params.meter_scoring:  # base_local_planner counts distances in cells
            self._path.scale = self.params.pdist_scale / resolution
            self._goal.scale = self.params.gdist_scale / resolution
        if (
            self._escape_from is not None
            and math.hypot(pose.x - self._escape_from[0], pose.y - self._escape_from[1])
            >= self.params.escape_reset_dist
        ):
            self._escape_from = None
        return super().compute_velocity(pose, velocity, grid, resolution, origin, footprint)

    def _window(self) -> float:
        return self.limits.sim_period if self.params.dwa else self.params.sim_time

    def _samples(self, vel: np.ndarray) -> np.ndarray:
        p, t = self.params, self._window()
        vx = linspace_window(
            max(p.min_vel_x, vel[0] - p.acc_lim_x * t),
            min(p.max_vel_x, vel[0] + p.acc_lim_x * t),
            p.vx_samples,
        )
        vx = vx[vx > 0.0] if self._escape_from is None else vx[:0]
        wlo = max(p.min_vel_theta, vel[2] - p.acc_lim_theta * t)
        whi = min(p.max_vel_theta, vel[2] + p.acc_lim_theta * t)
        w = linspace_window(wlo, whi, p.vtheta_samples)
        parts = [sample_grid(vx, np.zeros(1), w)]
        inplace = w[np.abs(w) >= p.min_in_place_vel_theta]  # rotate in place, above the friction floor
        floor = [s * p.min_in_place_vel_theta for s in (-1, 1) if wlo <= s * p.min_in_place_vel_theta <= whi]
        parts.append(sample_grid(np.zeros(1), np.zeros(1), np.unique(np.concatenate((inplace, floor)))))
        if p.holonomic_robot:
            parts.append(sample_grid(np.zeros(1), np.asarray(p.y_vels, float), np.zeros(1)))
        if self._escape_from is not None:
            parts.append(np.array([[p.escape_vel, 0.0, 0.0]]))
        return np.vstack(parts)

    def _simulate(self, pose: np.ndarray, vel: np.ndarray, samples: np.ndarray) -> Trajectories:
        p = self.params
        steps = num_steps(samples, p.sim_time, p.sim_granularity, p.angular_sim_granularity)
        acc = None if p.dwa else np.array([p.acc_lim_x, p.acc_lim_y, p.acc_lim_theta])
        return simulate(pose, vel, samples, p.sim_time, steps, acc)

    def _all_rejected(self, ctx: ScoringContext, trajs: Trajectories, reason: str) -> LocalResult:
        """Back up at escape_vel if that is collision-free (base_local_planner's escape)."""
        p = self.params
        if p.escape_vel < 0.0:
            back = simulate(
                ctx.pose,
                ctx.vel,
                np.array([[p.escape_vel, 0.0, 0.0]]),
                p.sim_time,
                num_steps(np.array([[p.escape_vel, 0, 0]]), p.sim_time, p.sim_granularity, 1.0),
            )
            self.collision.prepare(ctx)
            if self.collision.score(back)[0] >= 0:
                if self._escape_from is None:
                    self._escape_from = ctx.pose.copy()
                return LocalResult(
                    (p.escape_vel, 0.0, 0.0), True, f"escaping: {reason}", back.poses[0], len(trajs) + 1
                )
        return super()._all_rejected(ctx, trajs, reason)
