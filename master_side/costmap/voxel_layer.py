"""Voxel layer: an obstacle layer that marks and clears in 3D (costmap_2d::VoxelLayer).

Each column (x, y) holds z_voxels voxels from origin_z up, each marked, free or unknown (all start unknown).
Projection to 2D as costmap_2d does: marking a voxel makes its column LETHAL when the column has more than
mark_threshold marked voxels; a column touched by clearing with at most mark_threshold marked voxels
becomes FREE, or NO_INFORMATION if it still has more than unknown_threshold unknown voxels.
"""

from __future__ import annotations

import numpy as np

from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import shift_array
from master_side.costmap.layer import Bounds, register_layer
from master_side.costmap.layer_params import ObservationSourceParams, VoxelLayerParams
from master_side.costmap.observation import Observation
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.raytrace import trace_cells


@register_layer("costmap_2d::VoxelLayer", "nav2_costmap_2d::VoxelLayer", "VoxelLayer")
class VoxelLayer(ObstacleLayer):
    Params = VoxelLayerParams
    params: VoxelLayerParams

    def __init__(self, name: str, params, sources: dict[str, ObservationSourceParams] | None = None):
        super().__init__(name, params, sources)
        for n, src in (sources or {}).items():
            if src.min_mark_separation > 0:
                raise ValueError(f"{name}: source {n!r}: min_mark_separation is an ObstacleLayer option; "
                                 "the voxel layer marks voxels")
            if not src.footprint_clearing:
                raise ValueError(f"{name}: source {n!r}: footprint_clearing: false is an ObstacleLayer option; "
                                 "the voxel layer clears its voxels under the footprint")

    def match_size(self) -> None:
        super().match_size()
        shape = (self.params.z_voxels, self.costmap.size_y, self.costmap.size_x)
        self.marked = np.zeros(shape, bool)
        self.unknown = np.ones(shape, bool)

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        dx, dy = self.costmap.update_origin(new_origin_x, new_origin_y)
        if dx or dy:
            self.marked = shift_array(self.marked, dx, dy, False)
            self.unknown = shift_array(self.unknown, dx, dy, True)

    def reset(self) -> None:
        super().reset()
        self.marked[:] = False
        self.unknown[:] = True

    def clear_outside(self, outside: np.ndarray) -> None:
        super().clear_outside(outside)
        self.marked[:, outside] = False
        self.unknown[:, outside] = True

    def voxels(self) -> tuple[np.ndarray, np.ndarray]:
        """(marked, unknown) bool arrays (z, y, x), for display."""
        return self.marked, self.unknown

    @property
    def top_z(self) -> float:
        return self.params.origin_z + self.params.z_voxels * self.params.z_resolution

    def _mark(self, obs: Observation, bounds: Bounds) -> Bounds:
        p = self._marking_points(obs)
        p = p[(p[:, 2] >= self.params.origin_z) & (p[:, 2] < self.top_z)]
        cm = self.costmap
        mx, my, ok = cm.world_to_map(p[:, 0], p[:, 1])
        mz = ((p[ok, 2] - self.params.origin_z) / self.params.z_resolution).astype(np.int64)
        mx, my = mx[ok], my[ok]
        self.marked[mz, my, mx] = True
        self.unknown[mz, my, mx] = False
        column_marks = self.marked[:, my, mx].sum(axis=0)
        lethal = column_marks > self.params.mark_threshold
        cm.data[my[lethal], mx[lethal]] = LETHAL
        return bounds.expand_points(p[ok, 0], p[ok, 1])

    def _raytrace(self, obs: Observation, bounds: Bounds) -> Bounds:
        cm, pr = self.costmap, self.params
        o = obs.origin
        inside = bool(cm.world_to_map(o[0], o[1])[2]) and pr.origin_z <= o[2] < self.top_z
        if not inside or len(obs.points) == 0:
            return bounds  # the sensor is outside the voxel grid
        scale = np.array([cm.resolution, cm.resolution, pr.z_resolution])
        base = np.array([cm.origin_x, cm.origin_y, pr.origin_z])
        length = np.linalg.norm(obs.points - o, axis=1)
        t_limit = np.where(length > 0, obs.source.raytrace_range / np.maximum(length, 1e-12), 1.0)
        cx, cy, cz = trace_cells((o - base) / scale, (obs.points - base) / scale,
                                 (cm.size_x, cm.size_y, pr.z_voxels), t_limit)
        if len(cx) == 0:
            return bounds
        self.marked[cz, cy, cx] = False
        self.unknown[cz, cy, cx] = False
        # re-derive the 2D cost of the touched columns, over their bounding box
        x0, x1, y0, y1 = cx.min(), cx.max() + 1, cy.min(), cy.max() + 1
        touched = np.zeros((y1 - y0, x1 - x0), bool)
        touched[cy - y0, cx - x0] = True
        n_marked = self.marked[:, y0:y1, x0:x1].sum(axis=0)
        n_unknown = self.unknown[:, y0:y1, x0:x1].sum(axis=0)
        cleared = touched & (n_marked <= pr.mark_threshold)
        value = np.where(n_unknown <= pr.unknown_threshold, FREE, NO_INFORMATION).astype(np.uint8)
        np.copyto(cm.data[y0:y1, x0:x1], value, where=cleared)
        t = np.minimum(1.0, t_limit)[:, None]
        tips = o[:2] + (obs.points[:, :2] - o[:2]) * t
        return bounds.expand(o[0], o[1], o[0], o[1]).expand_points(tips[:, 0], tips[:, 1])
