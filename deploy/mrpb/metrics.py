"""MRPB's metrics of one run (J. Wen et al., "Evaluation Metrics for Mobile Robot Local Planning
Approaches", the benchmark's doc/main.pdf and doc/metrics.cpp), over the run's ground truth.

A run is sampled at each control cycle (MRPB logs at each call of the local planner): time, pose, linear
and angular speed. Computed here:

- safety: ``d_min_m``, the least distance from the robot's centre to the nearest obstacle, and
  ``danger_pct``, the share of the run's time spent within ``safe_distance_m`` of one. MRPB takes the
  distance from the local costmap's lethal cells; here it is from the simulated world's true occupied
  cells (a Euclidean distance transform between cell centres, bilinearly interpolated), so it measures
  the robot, not its perception. ``d_mean_m`` is added: the mean of that distance.
- efficiency: ``time_s`` from the goal to its end, ``path_m`` driven (the mean control cycle's wall time,
  MRPB's computational efficiency, comes from the run, not from here).
- smoothness: ``path_smoothness`` = sum over i of |dx_{i+1} - dx_i|^2 (m^2; dx_i the displacement between
  samples), ``accel_mean`` = the mean |dv/dt| (m/s^2, MRPB's velocity smoothness), and two additions:
  ``jerk_mean`` = the mean |d^2v/dt^2| (m/s^3) and ``ang_accel_mean`` = the mean |dw/dt| (rad/s^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from common.messages import OccupancyGrid

OCCUPIED = 65  # occupancy (0..100) from which a cell is an obstacle: MRPB's maps' occupied_thresh 0.65


@dataclass(frozen=True)
class DistanceField:
    """Distance (m) from each cell centre to the nearest occupied cell centre of a map."""
    dist: np.ndarray  # (height, width) float
    resolution: float
    origin: tuple[float, float]

    @staticmethod
    def of(grid: OccupancyGrid) -> DistanceField:
        free = np.asarray(grid.data) < OCCUPIED  # unknown (-1) is not an obstacle
        d = ndimage.distance_transform_edt(free) * grid.resolution
        return DistanceField(d, grid.resolution, (grid.origin.x, grid.origin.y))

    def at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bilinear interpolation between cell centres (outside the map: its border's value)."""
        c = (np.asarray(x, float) - self.origin[0]) / self.resolution - 0.5
        r = (np.asarray(y, float) - self.origin[1]) / self.resolution - 0.5
        return ndimage.map_coordinates(self.dist, [r, c], order=1, mode="nearest")


@dataclass(frozen=True)
class RunMetrics:
    time_s: float
    path_m: float
    d_min_m: float
    d_mean_m: float
    danger_pct: float
    path_smoothness: float
    accel_mean: float
    jerk_mean: float
    ang_accel_mean: float


def danger_share(t: np.ndarray, d: np.ndarray, safe: float) -> float:
    """MRPB's p_o: the time of each stretch of consecutive samples within ``safe`` (from its first sample
    to its last), summed, over the whole run's time, in percent."""
    if len(t) < 2 or t[-1] <= t[0]:
        return 0.0
    inside = np.concatenate([[False], d <= safe, [False]])
    edges = np.flatnonzero(np.diff(inside.astype(np.int8)))
    starts, ends = edges[0::2], edges[1::2] - 1
    return float(np.sum(t[ends] - t[starts]) / (t[-1] - t[0]) * 100.0)


def _mean_abs_rate(t: np.ndarray, v: np.ndarray) -> tuple[float, np.ndarray]:
    dt = np.diff(t)
    ok = dt > 1e-9
    rate = np.diff(v)[ok] / dt[ok]
    return (float(np.mean(np.abs(rate))) if len(rate) else 0.0), rate


def compute(trace: np.ndarray, field: DistanceField, safe_distance: float) -> RunMetrics:
    """``trace``: rows (t, x, y, yaw, v, w), one per control cycle, from the goal to the end of the run."""
    trace = np.asarray(trace, float).reshape(-1, 6)
    if len(trace) < 2:
        nan = math.nan
        return RunMetrics(nan, nan, nan, nan, nan, nan, nan, nan, nan)
    t, x, y, v, w = trace[:, 0], trace[:, 1], trace[:, 2], trace[:, 4], trace[:, 5]
    steps = np.stack([np.diff(x), np.diff(y)], axis=1)
    d = field.at(x, y)
    accel_mean, _ = _mean_abs_rate(t, v)
    # jerk: the rate of change of the acceleration between successive samples, at the midpoints' times
    dt = np.diff(t)
    ok = dt > 1e-9
    a, ta = np.diff(v)[ok] / dt[ok], (t[:-1] + dt / 2)[ok]
    jerk_mean, _ = _mean_abs_rate(ta, a) if len(a) > 1 else (0.0, None)
    ang_mean, _ = _mean_abs_rate(t, w)
    return RunMetrics(
        time_s=float(t[-1] - t[0]),
        path_m=float(np.sum(np.hypot(steps[:, 0], steps[:, 1]))),
        d_min_m=float(np.min(d)),
        d_mean_m=float(np.mean(d)),
        danger_pct=danger_share(t, d, safe_distance),
        path_smoothness=float(np.sum(np.sum(np.diff(steps, axis=0) ** 2, axis=1))),
        accel_mean=accel_mean,
        jerk_mean=jerk_mean,
        ang_accel_mean=ang_mean,
    )
