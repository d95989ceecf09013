"""Likelihood-field laser model (Thrun et al., Probabilistic Robotics 6.4; ROS amcl ``likelihood_field``).

Each beam end point is looked up in a precomputed map of the distance to the nearest occupied cell
(scipy's exact Euclidean distance transform, saturated at ``laser_likelihood_max_dist``; off the map
counts as saturated). A beam contributes ``pz = z_hit exp(-d² / 2σ²) + z_rand / range_max`` and, as in
ROS amcl, a particle's likelihood is ``1 + Σ pz³`` (a deliberately flattened, non-multiplicative
combination that keeps the filter from collapsing on a few beams). Beams at or beyond the maximum
range, below the minimum range, or not finite are skipped. All particles are scored at once.

``penalize_interior`` (zenav, default on): ROS gives every cell *inside* an obstacle distance 0, so a
pose pushed towards a thick obstacle (a crate, a 2-cell wall) scores as well as the true one; with a
narrow sensor that sees one face this biases the estimate forwards (measured 0.05-0.1 m with the
Kinect scan). With the option, the surface sits on the cell boundary and a cell that is not known
free scores its depth behind the free space (cells to the nearest free cell - 0.5) × resolution:
an obstacle cell that depth, an unknown cell the larger of that and its distance to an obstacle.
So an end point that went through a thin wall into the unknown space behind it (a SLAM map's outer
walls; ROS scores it by the wall's back face) is penalised by how far it went, while an end point in
unexplored open space scores at least as badly as in ROS. Free cells: (cells to the nearest
obstacle - 0.5) × resolution.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from common.geometry import Pose2D
from common.messages import OccupancyGrid

OCCUPIED_THRESHOLD = 65  # ROS amcl: occupancy > 65 is an obstacle, 0..(free_thresh) free, -1 unknown


def surface_distance(grid: OccupancyGrid, max_dist: float, penalize_interior: bool = True,
                     surface: str = "face") -> np.ndarray:
    """Per cell, the distance (m) to the nearest obstacle surface, saturated at ``max_dist``.

    Without ``penalize_interior``: ROS amcl's field, the distance to the nearest occupied cell's centre (0
    inside an obstacle), whatever ``surface``. With it, ``surface`` says where a surface lies in its cell:

    - ``face`` (the likelihood field's): on the face between the occupied cell and the free space, as in a
      map drawn from geometry (the simulator's worlds); free cells score (cells to the nearest obstacle -
      0.5) x resolution;
    - ``centre`` (refine.py's): at the centre of the first occupied cell, as in a laser SLAM's map, which
      marks the cell a beam ended in; free cells score ROS's distance. On intel's SLAM map the face put the
      scan's likelihood peak 4 cm behind SLAM's pose; interpolated between cell centres, the face's
      distances are also flat for half a cell either side of it.

    A cell that is not known free scores its depth behind the free space, counted from the surface (the
    module's docstring says why)."""
    occupied = grid.data > OCCUPIED_THRESHOLD
    free = (grid.data >= 0) & ~occupied
    if not occupied.any():
        return np.full(grid.data.shape, float(max_dist))
    if penalize_interior and free.any():
        free_offset, depth_offset = {"face": (0.5, 0.5), "centre": (0.0, 1.0)}[surface]  # in cells
        to_obstacle = distance_transform_edt(~occupied) - free_offset  # free: to the nearest surface
        behind_free = distance_transform_edt(~free) - depth_offset  # not free: depth behind the surface
        cells = np.where(free, to_obstacle, np.where(occupied, behind_free, np.maximum(to_obstacle, behind_free)))
    else:
        cells = distance_transform_edt(~occupied)
    return np.minimum(cells * float(grid.resolution), max_dist)


class LikelihoodField:
    """Distance map of one OccupancyGrid (``surface_distance``, surfaces on the faces) and the beam scoring
    over it."""

    def __init__(self, grid: OccupancyGrid, max_dist: float, penalize_interior: bool = True) -> None:
        self.resolution = float(grid.resolution)
        self.origin = np.array([grid.origin.x, grid.origin.y])  # origin yaw ignored, as in ROS amcl
        self.max_dist = float(max_dist)
        self.free = (grid.data >= 0) & ~(grid.data > OCCUPIED_THRESHOLD)
        self.dist = surface_distance(grid, self.max_dist, penalize_interior).astype(np.float32)

    def distance_at(self, xy: np.ndarray) -> np.ndarray:
        """Distance to the nearest obstacle at world points (..., 2); max_dist off the map."""
        ij = np.floor((xy - self.origin) / self.resolution).astype(np.int64)
        i, j = ij[..., 1], ij[..., 0]  # row = y, column = x
        h, w = self.dist.shape
        inside = (i >= 0) & (i < h) & (j >= 0) & (j < w)
        out = np.full(i.shape, self.max_dist, np.float32)
        out[inside] = self.dist[i[inside], j[inside]]
        return out

    def free_cell_centres(self) -> np.ndarray:
        """(K, 2) centres of the known-free cells (for global localisation)."""
        i, j = np.nonzero(self.free)
        return self.origin + (np.column_stack((j, i)) + 0.5) * self.resolution


def select_beams(ranges: np.ndarray, angles: np.ndarray, max_beams: int, range_min: float,
                 range_max: float) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_beams`` evenly spaced beams, then only the usable ones (min <= r < max, finite)."""
    n = len(ranges)
    idx = np.unique(np.linspace(0, n - 1, min(max_beams, n)).round().astype(np.int64))
    r, a = np.asarray(ranges, float)[idx], np.asarray(angles, float)[idx]
    ok = np.isfinite(r) & (r >= range_min) & (r < range_max)
    return r[ok], a[ok]


def beam_likelihoods(field: LikelihoodField, poses: np.ndarray, laser: Pose2D, ranges: np.ndarray,
                     angles: np.ndarray, z_hit: float, z_rand: float, sigma_hit: float,
                     range_max: float, product: bool = False) -> np.ndarray:
    """The likelihood-field weight of every pose (N, 3) of the robot base.

    ROS amcl's ``likelihood_field``: ``1 + Σ pz³``; with ``product`` its ``likelihood_field_prob``:
    ``Π pz`` (the proper joint likelihood of independent beams: much sharper, so a narrow sensor
    still pins the heading). ``laser`` is the scan frame in the base frame; ``ranges`` / ``angles``
    the usable beams."""
    poses = np.asarray(poses, float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise ValueError(f"poses must be (N, 3), got {poses.shape}")
    if len(ranges) == 0:
        return np.ones(len(poses))
    # beam end points in the base frame (B, 2), then in the map for every pose (N, B, 2)
    ends = laser.apply(np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles))))
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    wx = poses[:, 0:1] + c * ends[None, :, 0] - s * ends[None, :, 1]
    wy = poses[:, 1:2] + s * ends[None, :, 0] + c * ends[None, :, 1]
    d = field.distance_at(np.stack((wx, wy), axis=-1))
    pz = z_hit * np.exp(-(d.astype(float) ** 2) / (2.0 * sigma_hit**2)) + z_rand / range_max
    if product:
        return np.exp(np.sum(np.log(pz), axis=1))
    return 1.0 + np.sum(pz**3, axis=1)
