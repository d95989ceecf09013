"""Static layer: costs from an OccupancyGrid (costmap_2d::StaticLayer).

Values: unknown_cost_value -> NO_INFORMATION (track_unknown_space) or FREE; >= lethal_cost_threshold ->
LETHAL; otherwise FREE (trinary_costmap) or occupancy scaled to 0..LETHAL.
Fixed-window costmaps take the map's size, resolution and origin; a rolling costmap copies the part of
the map under its window (the map may be in another frame: give ``map_to_global``, and ``place`` the map
again whenever that transform changes — every update, as ROS's StaticLayer looks it up in updateCosts:
a local costmap in ``odom`` moves against ``map`` as localisation corrects the odometry's drift).
"""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D
from common.messages import OccupancyGrid
from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D, Window, update_with_max, update_with_true_overwrite
from master_side.costmap.layer import Bounds, Layer, register_layer
from master_side.costmap.layer_params import StaticLayerParams


def occupancy_lut(p: StaticLayerParams) -> np.ndarray:
    """256-entry table: OccupancyGrid byte (int8 viewed as uint8) -> cost."""
    v = np.arange(256)
    signed = np.where(v > 127, v - 256, v)  # the int8 occupancy value
    unknown = (signed == p.unknown_cost_value) | (v == p.unknown_cost_value)
    scaled = np.clip(signed, 0, None) / max(p.lethal_cost_threshold, 1) * LETHAL
    cost = np.where(signed >= p.lethal_cost_threshold, LETHAL, FREE if p.trinary_costmap else scaled)
    cost = np.where(unknown, NO_INFORMATION if p.track_unknown_space else FREE, cost)
    return np.clip(cost, 0, 255).astype(np.uint8)


@register_layer("costmap_2d::StaticLayer", "nav2_costmap_2d::StaticLayer", "StaticLayer")
class StaticLayer(Layer):
    Params = StaticLayerParams
    params: StaticLayerParams

    def __init__(self, name: str, params: StaticLayerParams):
        super().__init__(name, params)
        self.map: Costmap2D | None = None
        self.map_to_global = Pose2D()
        self._new_map = False
        self._lut = occupancy_lut(params)

    def set_map(self, grid: OccupancyGrid, map_to_global: Pose2D | None = None) -> bool:
        """A new map (``map_to_global``: pose of the map frame in the costmap's frame, rolling only);
        False when the layer keeps its first map instead (first_map_only)."""
        if self.map is not None and self.params.first_map_only:
            return False
        cm = Costmap2D(grid.width, grid.height, grid.resolution, grid.origin.x, grid.origin.y, NO_INFORMATION)
        cm.data = self._lut[grid.data.view(np.uint8)]
        self.map = cm
        self.map_to_global = map_to_global or Pose2D()
        self._new_map = True
        lc = self.layered
        if lc is not None and not lc.rolling_window and not lc.master.same_geometry(cm):
            lc.resize_map(cm.size_x, cm.size_y, cm.resolution, cm.origin_x, cm.origin_y)
        return True

    def place(self, map_to_global: Pose2D) -> None:
        """The map frame's pose in the costmap's frame now (rolling costmaps)."""
        self.map_to_global = map_to_global

    def update_bounds(self, robot_pose: Pose2D, bounds: Bounds) -> Bounds:
        if self.map is None:
            return bounds
        if self.layered.rolling_window:  # the window moves every cycle: copy all of it (as ROS)
            m = self.layered.master
            return bounds.expand(m.origin_x, m.origin_y, m.origin_x + m.size_in_meters_x,
                                 m.origin_y + m.size_in_meters_y)
        if not self._new_map:
            return bounds
        self._new_map = False
        m = self.map
        return bounds.expand(m.origin_x, m.origin_y, m.origin_x + m.size_in_meters_x,
                             m.origin_y + m.size_in_meters_y)

    def update_costs(self, master: Costmap2D, window: Window) -> None:
        if self.map is None:
            return
        if not self.layered.rolling_window and master.same_geometry(self.map):
            combine = update_with_max if self.params.use_maximum else update_with_true_overwrite
            combine(master, self.map.data, window)
            return
        gx, gy = np.meshgrid(np.arange(window.x0, window.xn), np.arange(window.y0, window.yn))
        wx, wy = master.map_to_world(gx, gy)
        local = self.map_to_global.inverse().apply(np.column_stack((wx.ravel(), wy.ravel())))
        mx, my, ok = self.map.world_to_map(local[:, 0], local[:, 1])
        ok = ok.reshape(gx.shape)
        values = np.full(gx.shape, NO_INFORMATION, np.uint8)
        values[ok] = self.map.data[my.reshape(gx.shape)[ok], mx.reshape(gx.shape)[ok]]
        dst = master.data[window.slices]
        if self.params.use_maximum:
            take = (values != NO_INFORMATION) & ((dst == NO_INFORMATION) | (values > dst))
            np.copyto(dst, values, where=take)
        else:
            np.copyto(dst, values, where=ok)  # outside the static map: leave the master as it is

    def reset(self) -> None:
        self._new_map = self.map is not None

    def grid(self) -> Costmap2D | None:
        return self.map
