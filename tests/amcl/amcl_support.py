"""Helpers for the AMCL tests: small maps, a grid ray caster, a noisy odometry drive."""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, LaserScan, OccupancyGrid

RES = 0.05


def box_map(width: float = 8.0, height: float = 6.0, boxes=((1.0, 1.0, 2.0, 1.6), (-2.5, -2.0, -1.5, 0.5),
                                                              (2.0, -2.2, 3.4, -1.6))) -> OccupancyGrid:
    """A walled room centred on the origin with axis-aligned boxes (x0, y0, x1, y1); asymmetric."""
    w, h = int(round(width / RES)), int(round(height / RES))
    data = np.zeros((h, w), np.int8)
    data[:2, :] = data[-2:, :] = 100
    data[:, :2] = data[:, -2:] = 100
    origin = Pose2D(-width / 2, -height / 2, 0.0)
    for x0, y0, x1, y1 in boxes:
        j0, j1 = int((x0 - origin.x) / RES), int((x1 - origin.x) / RES)
        i0, i1 = int((y0 - origin.y) / RES), int((y1 - origin.y) / RES)
        data[i0:i1, j0:j1] = 100
    return OccupancyGrid(Header(0.0, "map"), RES, origin, data)


def cast_scan(grid: OccupancyGrid, laser_pose: Pose2D, fov: float, beams: int, range_min: float,
              range_max: float, noise: float = 0.0, rng: np.random.Generator | None = None,
              stamp: float = 0.0) -> LaserScan:
    """Ray-march the grid from ``laser_pose`` (map frame); no return -> +inf."""
    angles = np.linspace(-fov / 2, fov / 2, beams)
    steps = np.arange(0.0, range_max, RES / 4)
    a = laser_pose.theta + angles
    xs = laser_pose.x + np.cos(a)[:, None] * steps[None, :]
    ys = laser_pose.y + np.sin(a)[:, None] * steps[None, :]
    j = np.floor((xs - grid.origin.x) / RES).astype(int)
    i = np.floor((ys - grid.origin.y) / RES).astype(int)
    inside = (i >= 0) & (i < grid.height) & (j >= 0) & (j < grid.width)
    occ = np.zeros(xs.shape, bool)
    occ[inside] = grid.data[i[inside], j[inside]] > 50
    first = np.where(occ.any(axis=1), occ.argmax(axis=1), -1)
    r = np.where(first >= 0, steps[first.clip(0)], np.inf)
    if noise and rng is not None:
        r = r + rng.normal(0.0, noise, len(r))
    r = np.where(r < range_min, np.inf, r)
    return LaserScan(Header(stamp, "laser"), float(angles[0]), float(angles[-1]),
                     float(angles[1] - angles[0]), 0.0, 0.0, range_min, range_max, r.astype(np.float32))


KINECT = {"fov": math.radians(57.0), "beams": 320, "range_min": 0.45, "range_max": 10.0}
LASER = {"fov": math.radians(240.0), "beams": 240, "range_min": 0.1, "range_max": 8.0}


def noisy_step(true_delta: Pose2D, rng: np.random.Generator, trans_sd: float = 0.02,
               rot_sd: float = 0.02) -> Pose2D:
    """An odometry increment with proportional noise (per metre / per radian moved)."""
    d = math.hypot(true_delta.x, true_delta.y)
    return Pose2D(true_delta.x + rng.normal(0, trans_sd * d + 1e-4),
                  true_delta.y + rng.normal(0, trans_sd * d),
                  true_delta.theta + rng.normal(0, rot_sd * abs(true_delta.theta) + 0.005 * d))


def pose_error(a: Pose2D, b: Pose2D) -> tuple[float, float]:
    return math.hypot(a.x - b.x, a.y - b.y), abs(math.remainder(a.theta - b.theta, 2 * math.pi))
