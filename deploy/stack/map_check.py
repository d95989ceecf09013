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
