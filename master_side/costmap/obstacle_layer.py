"""Obstacle layer: marks sensor hits LETHAL and ray-traces free space (costmap_2d::ObstacleLayer).

Per cycle: clear along every clearing ray (out to raytrace_range), then mark every marking point closer
than obstacle_range, then (footprint_clearing_enabled) free the cells under the robot; the layer's grid
is merged into the master with combination_method (0 overwrite, 1 maximum, 2 addition).
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, points_in_polygon
from master_side.costmap.cost_values import FREE, LETHAL
from master_side.costmap.costmap2d import (
    Costmap2D,
    Window,
    update_with_addition,
    update_with_max,
    update_with_overwrite,
)
from master_side.costmap.footprint import pad_footprint, transform_footprint
from master_side.costmap.layer import Bounds, CostmapLayer, register_layer
from master_side.costmap.layer_params import ObservationSourceParams, ObstacleLayerParams
from master_side.costmap.observation import Observation, ObservationBuffer
from master_side.costmap.raytrace import trace_cells

_COMBINE = {0: update_with_overwrite, 1: update_with_max, 2: update_with_addition}


@register_layer("costmap_2d::ObstacleLayer", "nav2_costmap_2d::ObstacleLayer", "ObstacleLayer")
class ObstacleLayer(CostmapLayer):
    Params = ObstacleLayerParams

    def __init__(self, name: str, params: ObstacleLayerParams,
                 sources: dict[str, ObservationSourceParams] | None = None):
        super().__init__(name, params)
        self.buffers = {n: ObservationBuffer(n, p) for n, p in (sources or {}).items()}
        self.footprint_world = np.zeros((0, 2))
        self._bare_world = np.zeros((0, 2))  # the robot's own outline (the padding off), for _keep_near_field
        self._under_body = np.zeros((0, 2))  # the cells freed when every source keeps its marks in the padding

    # -- input -----------------------------------------------------------------------------------
    def add_observation(self, source: str, points: np.ndarray, origin: np.ndarray, stamp: float) -> None:
        """A reading of ``source``: points (N, 3) and sensor origin (3,) in the costmap's global frame."""
        try:
            buf = self.buffers[source]
        except KeyError:
            have = sorted(self.buffers)
            raise KeyError(f"{self.name}: no observation source {source!r} (have {have})") from None
        buf.add(points, origin, stamp)

    def is_current(self, now: float) -> bool:
        return all(b.is_current(now) for b in self.buffers.values())

    def stale_sources(self, now: float) -> list[str]:
        return [n for n, b in self.buffers.items() if not b.is_current(now)]

    def _observations(self, kind: str) -> list[Observation]:
        return [o for b in self.buffers.values() if getattr(b.params, kind) for o in b.observations]

    # -- cycle -----------------------------------------------------------------------------------
    def update_bounds(self, robot_pose: Pose2D, bounds: Bounds) -> Bounds:
        clearing_footprint = self.params.footprint_clearing_enabled and len(self.layered.footprint)
        self.footprint_world = (transform_footprint(self.layered.footprint, robot_pose) if clearing_footprint
                                else np.zeros((0, 2)))
        pad = self.layered.footprint_padding
        kept = any(not b.params.footprint_clearing for b in self.buffers.values())
        keeps_all = not any(b.params.marking and b.params.footprint_clearing for b in self.buffers.values())
        bare = pad_footprint(self.layered.footprint, -pad) if clearing_footprint else np.zeros((0, 2))
        self._bare_world = (transform_footprint(bare, robot_pose) if clearing_footprint and kept and pad > 0
                            else np.zeros((0, 2)))
        # no marking source frees the padding: free only the cells wholly under the body, not those its outline
        # crosses, where a wall touching the flank is marked (a robot that had touched one saw room there and
        # pushed on into it: office02, 2026-11-29)
        self._under_body = (transform_footprint(pad_footprint(bare, -self.costmap.resolution), robot_pose)
                            if clearing_footprint and keeps_all else np.zeros((0, 2)))
        for obs in self._observations("clearing"):
            bounds = self._raytrace(obs, bounds)
        # sources with min_mark_separation last: they mark only where the others have not, this cycle included
        for obs in sorted(self._observations("marking"), key=lambda o: o.source.min_mark_separation > 0):
            bounds = self._mark(obs, bounds)
        if clearing_footprint:
            bounds = bounds.expand_points(self.footprint_world[:, 0], self.footprint_world[:, 1])
        return bounds

    def update_costs(self, master: Costmap2D, window: Window) -> None:
        if len(self._under_body):
            self.costmap.set_polygon_cost(self._under_body, FREE)
        elif self.params.footprint_clearing_enabled and len(self.footprint_world):
            self.costmap.set_polygon_cost(self.footprint_world, FREE)
            self._keep_near_field()
        _COMBINE[self.params.combination_method](master, self.costmap.data, window)

    def _keep_near_field(self) -> None:
        """Marks of ``footprint_clearing: false`` sources inside the padded footprint but outside the robot's own
        outline are marked again: a sonar hearing a wall 3 cm from the flank is a wall, not the robot (freed
        with the padding, the planner saw room there and turned the flank into it: office02's flank contacts).
        Beside sources that free the padding, only their current readings' marks can be told apart and kept;
        when no marking source frees the padding, the layer frees only the cells under the body (update_costs)."""
        keep = [o for b in self.buffers.values() if b.params.marking and not b.params.footprint_clearing
                for o in b.observations]
        if not keep or not len(self._bare_world):  # no padding: the footprint is the robot's outline
            return
        pts = np.vstack([self._marking_points(o) for o in keep])[:, :2]
        inside = points_in_polygon(pts[:, 0], pts[:, 1], self.footprint_world) & \
            ~points_in_polygon(pts[:, 0], pts[:, 1], self._bare_world)
        mx, my, ok = self.costmap.world_to_map(pts[inside, 0], pts[inside, 1])
        self.costmap.data[my[ok], mx[ok]] = LETHAL

    def reset(self) -> None:
        super().reset()
        for b in self.buffers.values():
            b.clear()

    def clear_outside(self, outside: np.ndarray) -> None:
        if self.costmap is None:
            return
        self.costmap.data[outside] = self.costmap.default_value
        for b in self.buffers.values():  # buffered readings would mark the cleared cells again
            b.clear()

    # -- marking / clearing (overridden by the voxel layer) ---------------------------------------
    def _marking_points(self, obs: Observation) -> np.ndarray:
        """Points that may mark: under max_obstacle_height and within [obstacle_min_range, obstacle_range)."""
        p = obs.points
        d2 = np.sum((p - obs.origin) ** 2, axis=1)
        s = obs.source
        keep = (p[:, 2] <= self.params.max_obstacle_height) & (d2 < s.obstacle_range ** 2)
        if s.obstacle_min_range > 0:
            keep &= d2 >= s.obstacle_min_range ** 2
        return p[keep]

    def _mark(self, obs: Observation, bounds: Bounds) -> Bounds:
        p = self._marking_points(obs)
        mx, my, ok = self.costmap.world_to_map(p[:, 0], p[:, 1])
        if obs.source.min_mark_separation > 0:
            ok &= self._unexplained(obs.origin, mx, my, obs.source.min_mark_separation, p[:, :2],
                                    obs.source.min_mark_separation_fov)
        self.costmap.data[my[ok], mx[ok]] = LETHAL
        return bounds.expand_points(p[ok, 0], p[ok, 1])

    def _unexplained(self, origin: np.ndarray, mx: np.ndarray, my: np.ndarray, radius: float,
                     points: np.ndarray | None = None, fov: float = 0.0) -> np.ndarray:
        """Per cell: does a reading there say something the layer does not have? False where a LETHAL cell of
        this layer within ``radius`` (a square window; meant for sparse sources, one window per point) lies
        nearer the sensor than the reading's own cell, or farther by one cell at most (centre to centre: the
        next cell in is a sonar's noise): an echo of a wall already
        marked (a sonar's, placed on its axis, may lie up to ``range * sin(fov / 2)`` sideways of the surface
        that returned it, which is no nearer than it). True where nothing is marked within ``radius``, or only
        farther: the echo says the obstacle is nearer than marked (a wall seen before the odometry slipped,
        office02's rear corners on physics: their marks 3-7 cm farther than the wall after a backing turn).
        Marks under the footprint do not count: footprint clearing erases them this cycle (a wall within the
        padding, beside the robot, would otherwise hide the echo of the same wall behind the robot's corner,
        outside the footprint: office02's rear-corner scrapes).

        ``fov`` > 0 (with the readings' ``points``): only marks within the sensor's cone count, within
        ``fov / 2`` (plus a cell) of the line from the sensor to the reading; a sonar hears the nearest surface
        in its cone only, so a wall beside it, outside the cone, explains nothing (office02, the Kinect robot:
        the marks of the wall it drove along, nearer than the wall's end, hid the echo of that end, a door
        jamb, and its flank struck the jamb turning round it)."""
        cm = self.costmap
        lethal = cm.data == LETHAL
        if len(self.footprint_world):
            fx, fy = cm.polygon_cells(self.footprint_world)
            lethal[fy, fx] = False
        k = int(np.ceil(radius / cm.resolution))
        h, w = lethal.shape
        # the sensor in cell units, from the map's corner (cell centres at index + 0.5)
        sx, sy = (origin[0] - cm.origin_x) / cm.resolution - 0.5, (origin[1] - cm.origin_y) / cm.resolution - 0.5
        out = np.ones(len(mx), bool)
        for i, (x, y) in enumerate(zip(mx.tolist(), my.tolist())):
            if not (0 <= x < w and 0 <= y < h):
                continue
            y0, x0 = max(0, y - k), max(0, x - k)
            ys, xs = np.nonzero(lethal[y0:y + k + 1, x0:x + k + 1])
            dx, dy = xs + x0 - sx, ys + y0 - sy
            dist = np.hypot(dx, dy)
            if ys.size and fov > 0 and points is not None:
                ax, ay = (points[i, 0] - origin[0]) / cm.resolution, (points[i, 1] - origin[1]) / cm.resolution
                off = np.abs(np.arctan2(ax * dy - ay * dx, ax * dx + ay * dy))  # each mark's angle off the axis
                within = off <= fov / 2 + 1.0 / np.maximum(dist, 1.0)  # a cell's width at its distance
                dist = dist[within]
            if dist.size:
                nearest = dist.min()
                out[i] = nearest > math.hypot(x - sx, y - sy) + 1.0 + 1e-6  # the next cell in: noise
        return out

    def _raytrace(self, obs: Observation, bounds: Bounds) -> Bounds:
        cm = self.costmap
        ox, oy = obs.origin[0], obs.origin[1]
        if not cm.world_to_map(ox, oy)[2] or len(obs.points) == 0:
            return bounds  # ROS: the sensor origin is off the map, cannot raytrace
        res = cm.resolution
        start = np.array([(ox - cm.origin_x) / res, (oy - cm.origin_y) / res])
        ends = (obs.points[:, :2] - np.array([cm.origin_x, cm.origin_y])) / res
        length = np.hypot(*(obs.points[:, :2] - obs.origin[:2]).T)
        t_limit = np.where(length > 0, obs.source.raytrace_range / np.maximum(length, 1e-12), 1.0)
        cx, cy = trace_cells(start, ends, (cm.size_x, cm.size_y), t_limit)
        if obs.source.raytrace_min_range > 0:
            wx, wy = cm.map_to_world(cx, cy)
            far = np.hypot(wx - ox, wy - oy) >= obs.source.raytrace_min_range
            cx, cy = cx[far], cy[far]
        cm.data.reshape(-1)[cy * cm.size_x + cx] = FREE
        # ROS updateRaytraceBounds: the origin and each ray's end (cut to the raytrace range)
        t = np.minimum(1.0, t_limit)[:, None]
        tips = obs.origin[:2] + (obs.points[:, :2] - obs.origin[:2]) * t
        return bounds.expand(ox, oy, ox, oy).expand_points(tips[:, 0], tips[:, 1])
