"""Pose refinement for AMCL (zenav's ``refine_pose``): the pose near a start where one scan is likeliest.

AMCL's estimate is the mean of its particle cloud, and the cloud follows the odometry: between updates it
moves by the odometry's increments, and each update only reweighs the particles it has. On the intel log
the cloud is ~1.5 cm wide yet sits ~5 cm from the pose the scan's own likelihood prefers (which is within
1 cm of SLAM's trajectory), because each odometry step moves the whole cloud by the same error and the
weights pull it back only in part (README, "AMCL on real logs").

This searches the joint likelihood of the scan, ``Σ log pz`` over its usable beams (the likelihood field's
beam model with the filter's z_hit / z_rand / sigma_hit), over a 7 × 7 × 7 lattice of poses around the
start, then twice more around the best candidate with finer steps. ``log pz`` is tabulated per cell, with
the surface at the occupied cells' centres as a laser SLAM's map has it (likelihood_field's
``surface_distance``: a map drawn from geometry, like the simulator's worlds, has its surfaces on the faces,
where this is half a cell off and refine_pose is not for it), and interpolated bilinearly between cell
centres, since the finest steps are a fraction of a cell. Where the
scan cannot tell candidates apart (along a featureless corridor) the one nearest the start wins: the
odometry's guess stands. The search reaches ±REACH_M and ±REACH_RAD: it corrects a tracked pose, it never
relocalises.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.jit import kernel
from common.messages import OccupancyGrid
from master_side.localization.likelihood_field import surface_distance

# (x/y step m, yaw step rad) of each pass; each pass searches ±HALF steps around the best of the last
STEPS = ((0.02, math.radians(1.0)), (0.007, math.radians(1.0 / 3.0)), (0.0025, math.radians(1.0 / 9.0)))
HALF = 3
REACH_M = HALF * sum(s[0] for s in STEPS)
REACH_RAD = HALF * sum(s[1] for s in STEPS)
_O = np.arange(-HALF, HALF + 1, dtype=float)
_LATTICE = np.stack(np.meshgrid(_O, _O, _O, indexing="ij"), axis=-1).reshape(-1, 3)
# a tie goes to the candidate nearest the start: a penalty far below any difference a beam makes
_TIE = 1e-9 * np.sum(_LATTICE**2, axis=1)


@kernel
def _scores(table, ox, oy, res, poses, bx, by):
    """Σ over beams of the bilinearly interpolated ``table`` (padded by one cell) at each pose's end points;
    (bx, by): the end points in the robot frame."""
    h, w = table.shape
    out = np.empty(poses.shape[0])
    for n in range(poses.shape[0]):
        c, s = math.cos(poses[n, 2]), math.sin(poses[n, 2])
        total = 0.0
        for b in range(bx.shape[0]):
            gx = (poses[n, 0] + c * bx[b] - s * by[b] - ox) / res + 0.5  # cell-centre units, padded
            gy = (poses[n, 1] + s * bx[b] + c * by[b] - oy) / res + 0.5
            gx = min(max(gx, 0.0), w - 1.000001)  # off the map: onto the border
            gy = min(max(gy, 0.0), h - 1.000001)
            j, i = int(gx), int(gy)
            fx, fy = gx - j, gy - i
            total += ((1.0 - fy) * ((1.0 - fx) * table[i, j] + fx * table[i, j + 1])
                      + fy * ((1.0 - fx) * table[i + 1, j] + fx * table[i + 1, j + 1]))
        out[n] = total
    return out


class PoseRefiner:
    """``log pz`` of one map per cell for one beam model, and the search over it."""

    def __init__(self, grid: OccupancyGrid, max_dist: float, penalize_interior: bool, z_hit: float, z_rand: float,
                 sigma_hit: float, range_max: float) -> None:
        def log_pz(d):
            return np.log(z_hit * np.exp(-(np.asarray(d, float) ** 2) / (2.0 * sigma_hit**2)) + z_rand / range_max)

        dist = surface_distance(grid, max_dist, penalize_interior, "centre")
        self.table = np.pad(log_pz(dist), 1, constant_values=float(log_pz(max_dist)))
        self.origin = np.array([grid.origin.x, grid.origin.y], float)  # origin yaw ignored, as in ROS amcl
        self.resolution = float(grid.resolution)

    def log_likelihoods(self, poses: np.ndarray, laser: Pose2D, ranges: np.ndarray,
                        angles: np.ndarray) -> np.ndarray:
        """``Σ log pz`` of the beams (usable ones, laser frame) for every robot pose (N, 3)."""
        ends = laser.apply(np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles))))
        return _scores(self.table, self.origin[0], self.origin[1], self.resolution,
                       np.ascontiguousarray(poses, float), np.ascontiguousarray(ends[:, 0]),
                       np.ascontiguousarray(ends[:, 1]))

    def refine(self, start: Pose2D, laser: Pose2D, ranges: np.ndarray, angles: np.ndarray) -> Pose2D:
        """The likeliest pose for the beams within reach of ``start``; ``start`` itself without beams."""
        if len(ranges) == 0:
            return start
        best = np.asarray(start.as_array(), float)
        for step_m, step_rad in STEPS:
            cand = best + _LATTICE * (step_m, step_m, step_rad)
            best = cand[int(np.argmax(self.log_likelihoods(cand, laser, ranges, angles) - _TIE))]
        return Pose2D(float(best[0]), float(best[1]), math.remainder(float(best[2]), 2 * math.pi))
