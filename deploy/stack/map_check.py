"""How well a SLAM map matches the simulator's world: distance of mapped walls from true walls."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from common.geometry import Pose2D
from common.messages import OccupancyGrid
from deploy.stack.world_maps import world_path
from robot_side.sim.world import WorldParams, load_world


@dataclass(frozen=True)
class MapAccuracy:
    occupied_cells: int
    within_two_cells: float  # fraction of mapped occupied cells within 2 map cells of a true obstacle
    mean_error_m: float
    p95_error_m: float

    def __str__(self) -> str:
        return (f"{self.occupied_cells} occupied cells, {100 * self.within_two_cells:.1f} % within two cells "
                f"of a true wall, mean {self.mean_error_m:.3f} m, p95 {self.p95_error_m:.3f} m")


def map_accuracy(grid: OccupancyGrid, world: str, map_in_world: Pose2D, min_height: float = 0.05) -> MapAccuracy:
    """Compare ``grid`` (frame whose pose in the world is ``map_in_world``) with the true world."""
    w = load_world(world_path(world), WorldParams(resolution=0.02))
    truth = w.occupied(min_height)  # (rows = y, cols = x) at w.resolution from w.origin
    dist = ndimage.distance_transform_edt(~truth) * w.resolution  # m to the nearest true obstacle
    rows, cols = np.nonzero(grid.data >= 65)
    if len(rows) == 0:
        return MapAccuracy(0, 0.0, float("inf"), float("inf"))
    pts = np.column_stack((grid.origin.x + (cols + 0.5) * grid.resolution,
                           grid.origin.y + (rows + 0.5) * grid.resolution))
    xy = map_in_world.apply(pts)
    c = np.floor((xy[:, 0] - w.origin[0]) / w.resolution).astype(int)
    r = np.floor((xy[:, 1] - w.origin[1]) / w.resolution).astype(int)
    inside = (r >= 0) & (c >= 0) & (r < dist.shape[0]) & (c < dist.shape[1])
    d = np.full(len(xy), np.inf)
    d[inside] = dist[r[inside], c[inside]]
    # a cell's centre is up to half a cell from the wall face it stands for
    err = np.maximum(d - grid.resolution / 2, 0.0)
    return MapAccuracy(len(err), float(np.mean(err <= 2 * grid.resolution)), float(np.mean(err[np.isfinite(err)])),
                       float(np.percentile(err, 95)))


def explored_share(grid: OccupancyGrid, world: str, map_in_world: Pose2D, min_height: float = 0.05,
                   margin_m: float = 0.1) -> tuple[float, float]:
    """(the share of ``world``'s free area the robot can reach that ``grid`` knows as free, that area in m²).
    The true area is sampled at the map's resolution; cells within ``margin_m`` of a true obstacle are left
    out (a wall's face falls anywhere within a map cell)."""
    w = load_world(world_path(world), WorldParams(resolution=grid.resolution))
    truth = w.to_occupancy_grid(min_height, unknown_unreachable=True).data
    near_wall = ndimage.distance_transform_edt(truth != 100) * w.resolution <= margin_m
    rows, cols = np.nonzero((truth == 0) & ~near_wall)
    pts = np.column_stack((w.origin[0] + (cols + 0.5) * w.resolution, w.origin[1] + (rows + 0.5) * w.resolution))
    xy = map_in_world.inverse().apply(pts)
    c = np.floor((xy[:, 0] - grid.origin.x) / grid.resolution).astype(int)
    r = np.floor((xy[:, 1] - grid.origin.y) / grid.resolution).astype(int)
    inside = (r >= 0) & (c >= 0) & (r < grid.data.shape[0]) & (c < grid.data.shape[1])
    known_free = np.zeros(len(xy), bool)
    known_free[inside] = (grid.data[r[inside], c[inside]] >= 0) & (grid.data[r[inside], c[inside]] < 25)
    return float(np.mean(known_free)) if len(xy) else 0.0, len(xy) * w.resolution**2
