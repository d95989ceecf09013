"""Inflation layer: exponential cost decay around LETHAL cells (costmap_2d::InflationLayer).

cost(d) = LETHAL at d = 0, INSCRIBED for d <= inscribed radius, else
floor(252 * exp(-cost_scaling_factor * (d - inscribed))) for d <= inflation_radius, else 0,
with d the Euclidean distance between cell centres. Computed with a distance transform over the
update window padded by the inflation radius, then a lookup table indexed by the squared cell distance.
The distance transform is exact and truncated at the radius: for radii up to SHIFT_MAX_CELLS cells a
separable two-pass min over shifted uint16 arrays (20x faster than scipy's EDT on the 500x500 global map),
beyond that scipy.ndimage.distance_transform_edt; both give identical squared distances within the radius.

Unknown cells (what ROS does, kept here): an inflated cost is written into a NO_INFORMATION master cell
only when it is >= INSCRIBED (or > FREE with ``inflate_unknown``); everywhere else the master becomes
max(old, cost). Inflation therefore never creates NO_INFORMATION (all inflated costs are <= LETHAL).
Difference to ROS 1: ROS rounds the radius up to whole cells (ceil(r / res)), so it also gives small costs
to cells up to one cell beyond ``inflation_radius``; zenav stops at ``inflation_radius``.
"""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, INSCRIBED, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D, Window
from master_side.costmap.layer import Bounds, Layer, register_layer
from master_side.costmap.layer_params import InflationLayerParams

SHIFT_MAX_CELLS = 32


def squared_distance_within(sources: np.ndarray, r: int) -> np.ndarray:
    """Squared Euclidean cell distance to the nearest True cell, exact up to r**2 (larger values > r**2).

    Pass 1: distance along each row (capped at r + 1); pass 2: min over dy of row_distance**2 + dy**2.
    """
    if r > SHIFT_MAX_CELLS:
        from scipy.ndimage import distance_transform_edt  # here only: a third of a second every costmap start

        d = distance_transform_edt(~sources)
        return np.minimum(np.rint(d * d), np.iinfo(np.int32).max).astype(np.int64)
    base = np.where(sources, np.uint16(0), np.uint16(r + 1))
    g = base.copy()
    for dx in range(1, r + 1):
        np.minimum(g[:, dx:], base[:, :-dx] + np.uint16(dx), out=g[:, dx:])
        np.minimum(g[:, :-dx], base[:, dx:] + np.uint16(dx), out=g[:, :-dx])
    sq = g * g
    d2 = sq.copy()
    for dy in range(1, r + 1):
        k = np.uint16(dy * dy)
        np.minimum(d2[dy:], sq[:-dy] + k, out=d2[dy:])
        np.minimum(d2[:-dy], sq[dy:] + k, out=d2[:-dy])
    return d2


def inflation_cost(distance_m: np.ndarray, inscribed_radius: float, inflation_radius: float,
                   cost_scaling_factor: float) -> np.ndarray:
    """Cost for distances (metres) from the nearest lethal cell (the formula above); uint8."""
    d = np.asarray(distance_m, float)
    decay = np.floor((INSCRIBED - 1) * np.exp(-cost_scaling_factor * (d - inscribed_radius)))
    cost = np.where(d <= inscribed_radius, INSCRIBED, np.clip(decay, 0, INSCRIBED - 1))
    cost = np.where(d > inflation_radius + 1e-9, FREE, cost)
    return np.where(d == 0.0, LETHAL, cost).astype(np.uint8)


@register_layer("costmap_2d::InflationLayer", "nav2_costmap_2d::InflationLayer", "InflationLayer")
class InflationLayer(Layer):
    Params = InflationLayerParams

    def __init__(self, name: str, params: InflationLayerParams):
        super().__init__(name, params)
        self.inscribed_radius = 0.0
        self.cell_inflation_radius = 0
        self.need_reinflation = True
        self._lut = np.zeros(1, np.uint8)
        self.costmap: Costmap2D | None = None  # last inflation costs, for display only

    def match_size(self) -> None:
        m = self.layered.master
        self.costmap = Costmap2D(m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y, FREE)
        self._compute_lut()

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        self.costmap.update_origin(new_origin_x, new_origin_y)

    def on_footprint_changed(self) -> None:
        self.inscribed_radius = self.layered.inscribed_radius
        self._compute_lut()

    def _compute_lut(self) -> None:
        """Cost by squared cell distance: lut[k] = cost(sqrt(k) * resolution)."""
        res = self.layered.master.resolution
        p = self.params
        self.cell_inflation_radius = self.layered.master.cell_distance(p.inflation_radius)
        k = np.arange(self.cell_inflation_radius ** 2 + 2)
        self._lut = inflation_cost(np.sqrt(k) * res, self.inscribed_radius, p.inflation_radius,
                                   p.cost_scaling_factor)
        self._lut[-1] = FREE  # everything farther than the radius
        self.need_reinflation = True

    def update_bounds(self, robot_pose: Pose2D, bounds: Bounds) -> Bounds:
        if self.need_reinflation:
            self.need_reinflation = False
            m = self.layered.master
            return bounds.expand(m.origin_x, m.origin_y, m.origin_x + m.size_in_meters_x,
                                 m.origin_y + m.size_in_meters_y)
        return bounds.padded(self.params.inflation_radius)

    def reset(self) -> None:
        self.costmap.reset()
        self.need_reinflation = True

    def grid(self) -> Costmap2D | None:
        return self.costmap

    def inflation_costs(self, master: Costmap2D, window: Window) -> np.ndarray:
        """Inflated cost (uint8) over ``window`` from the lethal cells of ``master`` near it."""
        pad = self.cell_inflation_radius + 1
        pw = window.padded(pad, master.size_x, master.size_y)
        sub = master.data[pw.slices]
        sources = sub == LETHAL
        if self.params.inflate_around_unknown:
            sources |= sub == NO_INFORMATION
        h, w = window.yn - window.y0, window.xn - window.x0
        if not sources.any():
            return np.zeros((h, w), np.uint8)
        d2 = squared_distance_within(sources, self.cell_inflation_radius)
        oy, ox = window.y0 - pw.y0, window.x0 - pw.x0
        k = np.minimum(d2[oy:oy + h, ox:ox + w], len(self._lut) - 1)
        return self._lut[k]

    def update_costs(self, master: Costmap2D, window: Window) -> None:
        if self.cell_inflation_radius == 0 and self.inscribed_radius <= 0:
            return
        cost = self.inflation_costs(master, window)
        self.costmap.data[window.slices] = cost
        m = master.data[window.slices]
        unknown = m == NO_INFORMATION
        np.maximum(m, cost, out=m)  # unknown (255) stays unknown here ...
        if unknown.any():  # ... unless the inflated cost may replace it (ROS rule)
            floor = FREE + 1 if self.params.inflate_unknown else INSCRIBED
            np.copyto(m, cost, where=unknown & (cost >= floor))

