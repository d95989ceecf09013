"""Tiny costmap builders and a kinematic loop for the planner tests."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from common.geometry import Pose2D
from master_side.planning.grid import INSCRIBED, LETHAL

P3AT_FOOTPRINT = np.array(
    [
        [0.3302, -0.0508],
        [0.254, -0.0508],
        [0.254, -0.254],
        [-0.254, -0.254],
        [-0.254, 0.254],
        [0.254, 0.254],
        [0.254, 0.0508],
        [0.3302, 0.0508],
    ]
)


def free_map(rows: int, cols: int) -> np.ndarray:
    return np.zeros((rows, cols), np.uint8)


def inflate(
    grid: np.ndarray, resolution: float, inscribed: float = 0.26, radius: float = 0.6, scaling: float = 10.0
) -> np.ndarray:
    """costmap_2d-like inflation of the LETHAL cells (INSCRIBED inside ``inscribed``, then exp decay)."""
    d = ndimage.distance_transform_edt(grid < LETHAL) * resolution
    decay = (INSCRIBED - 1) * np.exp(-scaling * (d - inscribed))
    cost = np.where(d <= inscribed, INSCRIBED, np.where(d <= radius, decay, 0)).astype(np.uint8)
    return np.maximum(grid, cost)


def drive(
    planner, start: Pose2D, grid: np.ndarray, resolution: float, footprint: np.ndarray, max_cycles: int = 2000
):
    """Integrate the planner's commands on a base that follows them within its acceleration limits
    (perfect kinematics otherwise) until the planner says the goal is reached.

    Returns (reached, poses (N, 3), commands (N, 3), results).
    """
    pose, vel = start, (0.0, 0.0, 0.0)
    dt = planner.limits.sim_period
    poses, cmds, results = [start.as_array()], [], []
    for _ in range(max_cycles):
        r = planner.compute_velocity(pose, vel, grid, resolution, (0.0, 0.0), footprint)
        results.append(r)
        acc = np.asarray(planner.limits.acc) * dt
        vel = tuple(float(v + np.clip(c - v, -a, a)) for v, c, a in zip(vel, r.cmd, acc))
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        pose = Pose2D(
            pose.x + (vel[0] * c - vel[1] * s) * dt,
            pose.y + (vel[0] * s + vel[1] * c) * dt,
            pose.theta + vel[2] * dt,
        )
        poses.append(pose.as_array())
        cmds.append(r.cmd)
        if planner.is_goal_reached(pose, vel):
            return True, np.array(poses), np.array(cmds), results
    return False, np.array(poses), np.array(cmds), results
