"""Tiny helper-built costmaps for the costmap tests."""

from __future__ import annotations

import numpy as np

from master_side.costmap.costmap2d import Costmap2D, update_with_max
from master_side.costmap.footprint import make_footprint_from_radius
from master_side.costmap.inflation_layer import InflationLayer
from master_side.costmap.layer import Bounds, CostmapLayer
from master_side.costmap.layer_params import (
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    VoxelLayerParams,
)
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.voxel_layer import VoxelLayer


class PaintLayer(CostmapLayer):
    """A layer whose grid the test paints directly; reports the whole map as changed."""

    def __init__(self, name: str = "paint"):
        super().__init__(name, None)

    def update_bounds(self, robot_pose, bounds: Bounds) -> Bounds:
        m = self.costmap
        return bounds.expand(m.origin_x, m.origin_y, m.origin_x + m.size_in_meters_x,
                             m.origin_y + m.size_in_meters_y)

    def update_costs(self, master, window) -> None:
        update_with_max(master, self.costmap.data, window)


def layered(size_m: float = 4.0, res: float = 0.1, *, rolling: bool = False, track_unknown: bool = False,
            origin=(0.0, 0.0), robot_radius: float = 0.2) -> LayeredCostmap:
    n = int(round(size_m / res))
    return LayeredCostmap(Costmap2D(n, n, res, *origin), rolling_window=rolling,
                          track_unknown_space=track_unknown,
                          footprint=make_footprint_from_radius(robot_radius))


def source(**kw) -> ObservationSourceParams:
    base = {"data_type": "LaserScan", "marking": True, "clearing": True, "obstacle_range": 2.5,
            "raytrace_range": 3.0, "min_obstacle_height": -1.0, "max_obstacle_height": 2.0}
    base.update(kw)
    return ObservationSourceParams(**base)


def obstacle_layer(lc: LayeredCostmap, *, footprint_clearing: bool = False, track_unknown: bool | None = None,
                   **src) -> ObstacleLayer:
    params = ObstacleLayerParams(footprint_clearing_enabled=footprint_clearing,
                                 track_unknown_space=track_unknown)
    return lc.add_layer(ObstacleLayer("obstacles", params, {"scan": source(**src)}))


def voxel_layer(lc: LayeredCostmap, *, track_unknown: bool | None = None, **kw) -> VoxelLayer:
    params = VoxelLayerParams(footprint_clearing_enabled=False, track_unknown_space=track_unknown, **kw)
    cloud = source(data_type="PointCloud2", obstacle_range=5.0, raytrace_range=5.0)
    return lc.add_layer(VoxelLayer("voxels", params, {"cloud": cloud}))


def inflation_layer(lc: LayeredCostmap, radius: float = 0.5, factor: float = 3.0, **kw) -> InflationLayer:
    return lc.add_layer(InflationLayer("inflation", InflationLayerParams(inflation_radius=radius,
                                                                         cost_scaling_factor=factor, **kw)))


def ring_scan(origin, ranges, z: float = 0.2) -> np.ndarray:
    """Points (N, 3) of a planar scan from ``origin`` (x, y) with one beam per entry of ``ranges``."""
    r = np.asarray(ranges, float)
    a = np.linspace(-np.pi, np.pi, len(r), endpoint=False)
    return np.column_stack((origin[0] + r * np.cos(a), origin[1] + r * np.sin(a), np.full(len(r), z)))


def beam(origin, end, z: float = 0.2) -> np.ndarray:
    return np.array([[end[0], end[1], z]], float), np.array([origin[0], origin[1], z], float)
