"""LayeredCostmap: runs plugin layers in order over a master grid (costmap_2d::LayeredCostmap).

Cycle (``update_map``): rolling window -> move the origin to keep the robot centred (whole cells, the
origin stays on the grid lattice); every enabled layer grows the bounds of what changed
(``update_bounds``); the master is reset over that window and every layer writes into it
(``update_costs``), in plugin order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from common.geometry import Pose2D, footprint_radii
from master_side.costmap import inflation_layer, obstacle_layer, static_layer, voxel_layer  # noqa: F401 (register)
from master_side.costmap.cost_values import FREE, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D, Window
from master_side.costmap.footprint import make_footprint_from_radius
from master_side.costmap.layer import LAYER_TYPES, Bounds, CostmapPlugin, layer_class, register_layer

if TYPE_CHECKING:
    from master_side.costmap.params import CostmapConfig

__all__ = ["LayeredCostmap", "register_layer", "layer_class", "LAYER_TYPES"]


class LayeredCostmap:
    def __init__(self, master: Costmap2D, *, rolling_window: bool = False, track_unknown_space: bool = False,
                 global_frame: str = "map", footprint: np.ndarray | None = None, footprint_padding: float = 0.0):
        self.rolling_window = rolling_window
        self.track_unknown_space = track_unknown_space
        self.global_frame = global_frame
        master.default_value = NO_INFORMATION if track_unknown_space else FREE
        master.reset()
        self.master = master
        self.layers: list[CostmapPlugin] = []
        self.footprint = np.zeros((0, 2))
        self.footprint_padding = float(footprint_padding)  # in ``footprint``: the robot's own outline is without it
        self.inscribed_radius = self.circumscribed_radius = 0.0
        self.last_window: Window | None = None
        self.initialized = False  # True after the first update_map
        self._full_update = False  # the next update_map recomputes the whole master (after clear_outside)
        self.set_footprint(make_footprint_from_radius(0.46) if footprint is None else footprint)

    @classmethod
    def from_config(cls, cfg: CostmapConfig) -> LayeredCostmap:
        """Build the master grid and the layers of a loaded configuration (``params.load_costmap_config``)."""
        c = cfg.costmap
        size_x, size_y = _cells(c.width, c.resolution), _cells(c.height, c.resolution)
        lc = cls(Costmap2D(size_x, size_y, c.resolution, c.origin_x, c.origin_y),
                 rolling_window=c.rolling_window, track_unknown_space=c.track_unknown_space,
                 global_frame=c.global_frame, footprint=np.array(cfg.footprint),
                 footprint_padding=c.footprint_padding)
        for spec in cfg.layers:
            kind = layer_class(spec.type)
            if spec.sources is None:
                layer = kind(spec.name, spec.params)
            else:  # observation layers (obstacle, voxel) also take their sources
                layer = kind(spec.name, spec.params, dict(spec.sources))  # type: ignore[call-arg]
            lc.add_layer(layer)
        return lc

    def add_layer(self, layer: CostmapPlugin) -> CostmapPlugin:
        if any(existing.name == layer.name for existing in self.layers):
            raise ValueError(f"costmap already has a layer named {layer.name!r}")
        self.layers.append(layer)
        layer.initialize(self)
        layer.on_footprint_changed()
        return layer

    def layer(self, name: str) -> CostmapPlugin:
        for layer in self.layers:
            if layer.name == name:
                return layer
        raise KeyError(f"no layer {name!r} (have {[x.name for x in self.layers]})")

    def set_footprint(self, footprint: np.ndarray) -> None:
        self.footprint = np.asarray(footprint, float).reshape(-1, 2)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        for layer in self.layers:
            layer.on_footprint_changed()

    def resize_map(self, size_x: int, size_y: int, resolution: float, origin_x: float,
                   origin_y: float) -> None:
        self.master.resize(size_x, size_y, resolution, origin_x, origin_y)
        for layer in self.layers:
            layer.match_size()

    def update_map(self, robot_pose: Pose2D) -> Window | None:
        """One update cycle at ``robot_pose`` (global frame). Returns the window that was recomputed."""
        m = self.master
        if self.rolling_window:
            new_x = robot_pose.x - m.size_in_meters_x / 2.0
            new_y = robot_pose.y - m.size_in_meters_y / 2.0
            m.update_origin(new_x, new_y)
            for layer in self.layers:
                layer.update_origin(new_x, new_y)
        enabled = [x for x in self.layers if x.enabled]
        bounds = Bounds()
        for layer in enabled:
            bounds = layer.update_bounds(robot_pose, bounds)
        if self._full_update:  # after a clear: recompute everything once
            self._full_update = False
            bounds = bounds.expand_points(np.array([m.origin_x, m.origin_x + m.size_in_meters_x]),
                                          np.array([m.origin_y, m.origin_y + m.size_in_meters_y]))
        self.initialized = True
        window = m.window_from_world(bounds.min_x, bounds.min_y, bounds.max_x, bounds.max_y)
        self.last_window = window
        if window is None:
            return None
        m.reset(window)
        for layer in enabled:
            layer.update_costs(m, window)
        return window

    def reset(self) -> None:
        """Clear every layer and the master (move_base 'clear costmaps' recovery)."""
        self.master.reset()
        for layer in self.layers:
            layer.reset()

    def clear_outside(self, robot_pose: Pose2D, distance: float) -> None:
        """ClearCostmapRecovery: every layer forgets what its sensors marked outside a square of side
        ``distance`` centred on the robot (the static layer keeps its map); the next update recomputes
        the whole master."""
        m = self.master
        xs = m.origin_x + (np.arange(m.size_x) + 0.5) * m.resolution
        ys = m.origin_y + (np.arange(m.size_y) + 0.5) * m.resolution
        inside_x = np.abs(xs - robot_pose.x) <= distance / 2.0
        inside_y = np.abs(ys - robot_pose.y) <= distance / 2.0
        outside = ~(inside_y[:, None] & inside_x[None, :])
        for layer in self.layers:
            layer.clear_outside(outside)
        self._full_update = True

    def is_current(self, now: float) -> bool:
        return all(x.is_current(now) for x in self.layers if x.enabled)

    def stale_sources(self, now: float) -> list[str]:
        out: list[str] = []
        for x in self.layers:
            if x.enabled:
                out += [f"{x.name}/{s}" for s in x.stale_sources(now)]
        return out


def _cells(meters: float, resolution: float) -> int:
    """Cells for a size in metres (ROS truncates; a tiny tolerance absorbs 0.3 / 0.1 = 2.9999...)."""
    return int(meters / resolution + 1e-6)
