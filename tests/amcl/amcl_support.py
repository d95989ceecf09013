"""Helpers for the AMCL tests: small maps, grid ray casters, a noisy odometry drive."""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import binary_erosion

from common.geometry import Pose2D
from common.messages import Header, LaserScan, OccupancyGrid

RES = 0.05


def route(waypoints, step: float = 0.1, turn: float = 0.1) -> list[Pose2D]:
    """Poses along straight legs between waypoints, turning on the spot at each."""
    poses = [Pose2D(*waypoints[0])]
    for x, y in waypoints[1:]:
        p = poses[-1]
        head = math.atan2(y - p.y, x - p.x)
        while (d := math.remainder(head - p.theta, 2 * math.pi)) != 0.0:
            p = Pose2D(p.x, p.y, p.theta + max(-turn, min(turn, d)))
            poses.append(p)
        n = math.ceil(math.hypot(x - p.x, y - p.y) / step)
        poses += [Pose2D(p.x + (x - p.x) * k / n, p.y + (y - p.y) * k / n, head) for k in range(1, n + 1)]
    return poses


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


def solid_world(grid: OccupancyGrid, surface: str = "cell_centre") -> np.ndarray:
    """The world a map implies, on a grid ten times finer. ``cell_centre`` (a laser SLAM's map: a beam marks
    the cell it ends in): each obstacle's surface at the centre of its outer cells, the obstacles shrunk by
    half a cell; ``cell_face`` (a map drawn from geometry): the occupied cells themselves."""
    occupied = np.kron(grid.data > 50, np.ones((10, 10), bool))
    if surface == "cell_face":
        return occupied
    return binary_erosion(occupied, iterations=5, border_value=1)  # the cross erodes faces exactly 5 cells


def cast(grid: OccupancyGrid, solid: np.ndarray, laser: Pose2D, step: float = 0.001) -> np.ndarray:
    """LASER's ranges from the ``laser`` pose (map frame) in ``solid`` (inf: no return), within ``step``."""
    fine_res = RES / 10
    angles = np.linspace(-LASER["fov"] / 2, LASER["fov"] / 2, LASER["beams"])
    steps = np.arange(0.0, LASER["range_max"], step)
    a = laser.theta + angles
    j = np.floor((laser.x + np.cos(a)[:, None] * steps - grid.origin.x) / fine_res).astype(int)
    i = np.floor((laser.y + np.sin(a)[:, None] * steps - grid.origin.y) / fine_res).astype(int)
    inside = (i >= 0) & (i < solid.shape[0]) & (j >= 0) & (j < solid.shape[1])
    hit = np.zeros(j.shape, bool)
    hit[inside] = solid[i[inside], j[inside]]
    return np.where(hit.any(axis=1), steps[hit.argmax(axis=1)], np.inf)


def noisy_step(true_delta: Pose2D, rng: np.random.Generator, trans_sd: float = 0.02,
               rot_sd: float = 0.02) -> Pose2D:
    """An odometry increment with proportional noise (per metre / per radian moved)."""
    d = math.hypot(true_delta.x, true_delta.y)
    return Pose2D(true_delta.x + rng.normal(0, trans_sd * d + 1e-4),
                  true_delta.y + rng.normal(0, trans_sd * d),
                  true_delta.theta + rng.normal(0, rot_sd * abs(true_delta.theta) + 0.005 * d))


def pose_error(a: Pose2D, b: Pose2D) -> tuple[float, float]:
    return math.hypot(a.x - b.x, a.y - b.y), abs(math.remainder(a.theta - b.theta, 2 * math.pi))
