"""A 2D cost grid (costmap_2d::Costmap2D): uint8 ``data[row=y, col=x]``, origin at the corner of cell (0, 0).

Cell (mx, my) covers [origin + m*res, origin + (m+1)*res); its centre is origin + (m + 0.5)*res.
A ``Window`` is a half-open cell rectangle [x0, xn) x [y0, yn) (ROS's update window).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from common.geometry import Pose2D, points_in_polygon
from common.messages import Costmap, Header
from master_side.costmap.cost_values import NO_INFORMATION


class Window(NamedTuple):
    x0: int
    y0: int
    xn: int
    yn: int

    @property
    def slices(self) -> tuple[slice, slice]:
        """Index ``data[window.slices]`` (row = y first)."""
        return slice(self.y0, self.yn), slice(self.x0, self.xn)

    def is_empty(self) -> bool:
        return self.xn <= self.x0 or self.yn <= self.y0

    def padded(self, cells: int, size_x: int, size_y: int) -> Window:
        """Grown by ``cells`` on every side, clipped to a size_x x size_y grid."""
        return Window(max(0, self.x0 - cells), max(0, self.y0 - cells),
                      min(size_x, self.xn + cells), min(size_y, self.yn + cells))


def shift_array(arr: np.ndarray, dx: int, dy: int, fill: int | bool) -> np.ndarray:
    """``out[..., y, x] = arr[..., y + dy, x + dx]`` where defined, else ``fill`` (last two axes are y, x)."""
    out = np.full_like(arr, fill)
    h, w = arr.shape[-2:]
    if abs(dx) >= w or abs(dy) >= h:
        return out
    sx0, sx1 = max(0, dx), min(w, w + dx)
    sy0, sy1 = max(0, dy), min(h, h + dy)
    out[..., sy0 - dy:sy1 - dy, sx0 - dx:sx1 - dx] = arr[..., sy0:sy1, sx0:sx1]
    return out


class Costmap2D:
    """Grid geometry + uint8 costs; all coordinate conversions take scalars or numpy arrays."""

    def __init__(self, size_x: int, size_y: int, resolution: float, origin_x: float = 0.0,
                 origin_y: float = 0.0, default_value: int = 0):
        if size_x < 0 or size_y < 0 or resolution <= 0:
            raise ValueError(f"bad costmap geometry {size_x}x{size_y} at {resolution} m")
        self.resolution = float(resolution)
        self.origin_x, self.origin_y = float(origin_x), float(origin_y)
        self.default_value = int(default_value)
        self.data = np.full((int(size_y), int(size_x)), self.default_value, np.uint8)

    # -- geometry ---------------------------------------------------------------------------------
    @property
    def size_x(self) -> int:
        return int(self.data.shape[1])

    @property
    def size_y(self) -> int:
        return int(self.data.shape[0])

    @property
    def size_in_meters_x(self) -> float:
        return self.size_x * self.resolution

    @property
    def size_in_meters_y(self) -> float:
        return self.size_y * self.resolution

    def full_window(self) -> Window:
        return Window(0, 0, self.size_x, self.size_y)

    def same_geometry(self, other: Costmap2D) -> bool:
        return (self.data.shape == other.data.shape and self.resolution == other.resolution
                and self.origin_x == other.origin_x and self.origin_y == other.origin_y)

    def world_to_map(self, wx, wy):
        """Cell indices (floor) and a validity mask / bool: ``(mx, my, inside)``."""
        fx = np.floor((np.asarray(wx, float) - self.origin_x) / self.resolution)
        fy = np.floor((np.asarray(wy, float) - self.origin_y) / self.resolution)
        inside = (fx >= 0) & (fy >= 0) & (fx < self.size_x) & (fy < self.size_y)
        return fx.astype(np.int64), fy.astype(np.int64), inside

    def world_to_map_enforce_bounds(self, wx, wy):
        """Like ``world_to_map`` but clamped to the grid (costmap_2d worldToMapEnforceBounds)."""
        mx, my, _ = self.world_to_map(wx, wy)
        return np.clip(mx, 0, max(self.size_x - 1, 0)), np.clip(my, 0, max(self.size_y - 1, 0))

    def map_to_world(self, mx, my):
        """World coordinates of cell centres."""
        return (self.origin_x + (np.asarray(mx, float) + 0.5) * self.resolution,
                self.origin_y + (np.asarray(my, float) + 0.5) * self.resolution)

    def cell_distance(self, world_dist: float) -> int:
        """Whole cells covering ``world_dist`` (rounded up, as costmap_2d cellDistance)."""
        return max(0, math.ceil(world_dist / self.resolution - 1e-9))

    def window_from_world(self, min_x: float, min_y: float, max_x: float, max_y: float) -> Window | None:
        """Cells touched by a world rectangle, clamped to the grid; None if the rectangle is empty."""
        if not (min_x <= max_x and min_y <= max_y) or self.size_x == 0 or self.size_y == 0:
            return None
        x0, y0 = self.world_to_map_enforce_bounds(min_x, min_y)
        x1, y1 = self.world_to_map_enforce_bounds(max_x, max_y)
        w = Window(int(x0), int(y0), int(x1) + 1, int(y1) + 1)
        return None if w.is_empty() else w

    # -- content ----------------------------------------------------------------------------------
    def resize(self, size_x: int, size_y: int, resolution: float, origin_x: float, origin_y: float) -> None:
        self.resolution, self.origin_x, self.origin_y = float(resolution), float(origin_x), float(origin_y)
        self.data = np.full((int(size_y), int(size_x)), self.default_value, np.uint8)

    def reset(self, window: Window | None = None) -> None:
        """Set a window (default: everything) to the default value."""
        self.data[(window or self.full_window()).slices] = self.default_value

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> tuple[int, int]:
        """Move the grid by whole cells towards a new origin, keeping world-consistent content.

        As costmap_2d: the shift is the truncated number of cells of the offset, so the origin stays
        on the old grid lattice; cells that enter the grid get the default value. Returns (dx, dy).
        """
        dx = int((new_origin_x - self.origin_x) / self.resolution)
        dy = int((new_origin_y - self.origin_y) / self.resolution)
        if dx or dy:
            self.data = shift_array(self.data, dx, dy, self.default_value)
            self.origin_x += dx * self.resolution
            self.origin_y += dy * self.resolution
        return dx, dy

    def get_cost(self, wx: float, wy: float) -> int:
        """Cost at a world point (NO_INFORMATION outside the grid)."""
        mx, my, ok = self.world_to_map(wx, wy)
        return int(self.data[my, mx]) if ok else NO_INFORMATION

    def polygon_cells(self, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cells covered by a polygon (N, 2) in world coordinates: centres inside plus the outline."""
        poly = np.asarray(polygon, float)
        if len(poly) == 0 or self.size_x == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        x0, y0 = self.world_to_map_enforce_bounds(poly[:, 0].min(), poly[:, 1].min())
        x1, y1 = self.world_to_map_enforce_bounds(poly[:, 0].max(), poly[:, 1].max())
        gx, gy = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1))
        wx, wy = self.map_to_world(gx.ravel(), gy.ravel())
        inside = points_in_polygon(wx, wy, poly)
        # outline: sample every edge at quarter-cell steps so thin polygons still cover their cells
        a, b = poly, np.roll(poly, -1, axis=0)
        n = max(2, int(np.ceil(np.max(np.hypot(*(b - a).T)) / (0.25 * self.resolution))) + 1)
        t = np.linspace(0.0, 1.0, n)[None, :]
        ex = (a[:, :1] + (b[:, :1] - a[:, :1]) * t).ravel()
        ey = (a[:, 1:] + (b[:, 1:] - a[:, 1:]) * t).ravel()
        ox, oy, ok = self.world_to_map(ex, ey)
        return (np.concatenate((gx.ravel()[inside], ox[ok])), np.concatenate((gy.ravel()[inside], oy[ok])))

    def set_polygon_cost(self, polygon: np.ndarray, value: int) -> None:
        """costmap_2d setConvexPolygonCost (works for any simple polygon)."""
        mx, my = self.polygon_cells(polygon)
        self.data[my, mx] = value

    def published(self, unknown_as: int | None = None) -> np.ndarray:
        """A copy of the grid as the costmap topic carries it: NO_INFORMATION cells at ``unknown_as`` if given
        (CostmapParams.unseen_as)."""
        data = self.data.copy()
        if unknown_as is not None:
            data[data == NO_INFORMATION] = unknown_as
        return data

    def to_message(self, header: Header, layer: str = "", unknown_as: int | None = None) -> Costmap:
        origin = Pose2D(self.origin_x, self.origin_y, 0.0)
        return Costmap(header=header, resolution=self.resolution, origin=origin, data=self.published(unknown_as),
                       layer=layer)


# -- combining a layer's grid into the master (CostmapLayer helpers), grids must be aligned -----------
def update_with_max(master: Costmap2D, layer: np.ndarray, window: Window) -> None:
    """Master = max(master, layer) where the layer knows something; unknown master cells take the layer."""
    m, s = master.data[window.slices], layer[window.slices]
    take = (s != NO_INFORMATION) & ((m == NO_INFORMATION) | (s > m))
    np.copyto(m, s, where=take)


def update_with_overwrite(master: Costmap2D, layer: np.ndarray, window: Window) -> None:
    """Master = layer wherever the layer is not NO_INFORMATION."""
    m, s = master.data[window.slices], layer[window.slices]
    np.copyto(m, s, where=s != NO_INFORMATION)


def update_with_true_overwrite(master: Costmap2D, layer: np.ndarray, window: Window) -> None:
    """Master = layer, unknown included."""
    master.data[window.slices] = layer[window.slices]


def update_with_addition(master: Costmap2D, layer: np.ndarray, window: Window) -> None:
    """Master = min(master + layer, INSCRIBED - 1) where both are known; unknown master takes the layer."""
    m, s = master.data[window.slices], layer[window.slices]
    summed = np.minimum(m.astype(np.int16) + s, 252).astype(np.uint8)
    out = np.where(m == NO_INFORMATION, s, summed)
    np.copyto(m, out, where=s != NO_INFORMATION)
