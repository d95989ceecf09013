"""The simulated 2.5D world: a height grid (max obstacle height per cell, metres above the floor).

Loaded from a map_server map (PGM + YAML; occupied cells become obstacles ``map_obstacle_height`` tall)
or from a YAML of shapes with heights (walls, boxes, cylinders). Shapes are rasterised by testing each
cell *centre*; the grid is in ROS order: row 0 is the lowest y, cell (0, 0)'s corner at ``origin``.

Shapes YAML::

    bounds: [xmin, ymin, xmax, ymax]        # optional, else shapes' extent + margin
    start: [x, y, theta]                    # default start pose (map frame)
    goals: {name: [x, y, theta], ...}       # suggested goals (a list is accepted too)
    walls:     [{from: [x, y], to: [x, y], thickness: 0.1, height: 2.0}]   # square caps
    boxes:     [{center: [x, y], size: [sx, sy], yaw: 0.0, height: 0.5}]   # movable: true, mass: 5.0 (kg):
                                            # the MuJoCo engine lets the robot push it (static otherwise)
    cylinders: [{center: [x, y], radius: 0.2, height: 0.8}]

The shapes themselves are ``robot_side.sim.world_shapes``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from common.config import ConfigError, param, read_yaml
from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from common.pgm import read_pgm
from robot_side.sim.world_shapes import Box, grid_boxes, parse_shapes

__all__ = ["WorldParams", "World", "is_map_world", "load_world", "parse_pose"]


@dataclass(frozen=True)
class WorldParams:
    resolution: float = param(0.02, lo=0.005, hi=0.5, unit="m", doc="cell size of the simulated height grid")
    map_obstacle_height: float = param(2.0, lo=0.01, hi=100.0, unit="m",
                                       doc="height of occupied cells of a map_server map")
    unknown_is_obstacle: bool = param(False, doc="map_server 'unknown' cells become obstacles (else free)")
    margin: float = param(0.5, lo=0.0, hi=100.0, unit="m", doc="free border around shapes without bounds")
    edge_walls: bool = param(False, doc="a map_server map's world ends where its map's content does: wall outside "
                             "the bounding box of its occupied and unknown cells, and along the map's edge (else "
                             "the floor goes on, empty, beyond it)")


def parse_pose(value: Any, source: str = "<world>", key: str = "pose") -> Pose2D:
    """A pose from ``[x, y, theta]``, ``[x, y]`` or ``{x:, y:, theta:}``; a Pose2D passes through."""
    if isinstance(value, Pose2D):
        return value
    if isinstance(value, dict):
        value = [value.get("x", 0.0), value.get("y", 0.0), value.get("theta", value.get("yaw", 0.0))]
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
        raise ConfigError(source, key, f"expected [x, y, theta], got {value!r}")
    try:
        v = [float(a) for a in value]
    except (TypeError, ValueError) as e:
        raise ConfigError(source, key, f"expected numbers, got {value!r}") from e
    return Pose2D(v[0], v[1], v[2] if len(v) == 3 else 0.0)


def _goals(value: Any, source: str) -> dict[str, Pose2D]:
    if value is None:
        return {}
    if isinstance(value, dict):
        return {str(k): parse_pose(v, source, f"goals.{k}") for k, v in value.items()}
    if isinstance(value, list):
        return {f"goal{i}": parse_pose(v, source, f"goals[{i}]") for i, v in enumerate(value)}
    raise ConfigError(source, "goals", "expected a mapping name -> [x, y, theta] or a list")


_ORIGIN = Pose2D()


class World:
    """Height grid ``heights`` (rows = y, float32 metres) plus start pose and named goals."""

    def __init__(self, heights: np.ndarray, resolution: float, origin: tuple[float, float] = (0.0, 0.0),
                 start: Pose2D = _ORIGIN, goals: dict[str, Pose2D] | None = None, name: str = "",
                 shapes: list[Box] | None = None):
        self.heights = np.ascontiguousarray(heights, dtype=np.float32)
        if self.heights.ndim != 2 or min(self.heights.shape) < 1:
            raise ValueError("heights must be a non-empty 2D array")
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))
        self.start = start
        self.goals = dict(goals or {})
        self.name = name
        # the solid shapes (a physics engine's geoms); None: only the grid is known (a map_server map)
        self.shapes = list(shapes) if shapes is not None else None

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape  # (rows, cols)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the grid in metres."""
        x0, y0 = self.origin
        return x0, y0, x0 + self.shape[1] * self.resolution, y0 + self.shape[0] * self.resolution

    def with_start(self, start: Any) -> World:
        """The same world with another start pose (``[x, y, theta]``, dict or Pose2D)."""
        return World(self.heights, self.resolution, self.origin, parse_pose(start), self.goals, self.name,
                     self.shapes)

    def solid_boxes(self) -> list[Box]:
        """The world as boxes and cylinders: its shapes, or boxes merged from the grid's obstacle cells."""
        if self.shapes is not None:
            return list(self.shapes)
        return grid_boxes(self.heights, self.origin, self.resolution)

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Obstacle height under world points (0 outside the grid)."""
        ix, iy = self.cell_of(x, y)
        inside = (ix >= 0) & (iy >= 0) & (ix < self.shape[1]) & (iy < self.shape[0])
        out = np.zeros(np.shape(ix), np.float32)
        out[inside] = self.heights[iy[inside], ix[inside]]
        return out

    def add_box(self, cx: float, cy: float, sx: float, sy: float, height: float, yaw: float = 0.0) -> None:
        """Put a box into the world now (a person, a dropped crate); sensors see it after ``refresh``."""
        vals = (cx, cy, sx, sy, height, yaw)
        if not all(math.isfinite(v) for v in vals) or sx <= 0 or sy <= 0 or height <= 0:
            raise ValueError(f"bad box {vals}: centre, positive size and height must be finite")
        box = Box(cx, cy, sx, sy, yaw, height)
        box.rasterise(self.heights, self.origin, self.resolution)
        if self.shapes is not None:
            self.shapes.append(box)

    def occupied(self, min_height: float = 0.0) -> np.ndarray:
        """Cells whose obstacle is taller than ``min_height``."""
        return self.heights > min_height

    def to_occupancy_grid(self, min_height: float = 0.0, stamp: float = 0.0, frame_id: str = "map",
                          unknown_unreachable: bool = False) -> OccupancyGrid:
        """Ground-truth map as a ROS OccupancyGrid (100 = obstacle taller than ``min_height``, 0 free).

        ``unknown_unreachable``: free cells the robot cannot reach from its start (outside the outer
        walls, inside closed obstacles) are -1, as in a map a robot built (SLAM never sees them)."""
        occupied = self.occupied(min_height)
        data = np.where(occupied, 100, 0).astype(np.int8)
        if unknown_unreachable:
            from scipy import ndimage  # here only: half a second of import every simulator start would pay

            labels, _ = ndimage.label(~occupied)  # 4-connected free regions
            ix, iy = self.cell_of(self.start.x, self.start.y)
            if 0 <= iy < labels.shape[0] and 0 <= ix < labels.shape[1] and labels[iy, ix] > 0:
                data[~occupied & (labels != labels[iy, ix])] = -1
        return OccupancyGrid(Header(stamp, frame_id), self.resolution, Pose2D(*self.origin, 0.0), data)

    def cell_of(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(column, row) int64 indices of the cells holding the points (x, y) (may lie off the grid)."""
        return (np.floor((np.asarray(x) - self.origin[0]) / self.resolution).astype(np.int64),
                np.floor((np.asarray(y) - self.origin[1]) / self.resolution).astype(np.int64))

    # ------------------------------------------------------------------ loaders
    @classmethod
    def from_shapes(cls, spec: dict, params: WorldParams = WorldParams(), source: str = "<world>") -> World:
        allowed = {"name", "bounds", "start", "goals", "walls", "boxes", "cylinders", "resolution"}
        for k in spec:
            if k not in allowed:
                raise ConfigError(source, str(k), f"unknown key (known keys: {', '.join(sorted(allowed))})")
        res = float(spec.get("resolution", params.resolution))
        shapes = parse_shapes(spec, source)
        if "bounds" in spec:
            b = spec["bounds"]
            if not (isinstance(b, (list, tuple)) and len(b) == 4 and b[0] < b[2] and b[1] < b[3]):
                raise ConfigError(source, "bounds", f"expected [xmin, ymin, xmax, ymax], got {b!r}")
            xmin, ymin, xmax, ymax = map(float, b)
        elif shapes:
            ext = np.array([s.extent() for s in shapes])
            m = params.margin
            xmin, ymin = ext[:, 0].min() - m, ext[:, 1].min() - m
            xmax, ymax = ext[:, 2].max() + m, ext[:, 3].max() + m
        else:
            raise ConfigError(source, "bounds", "a world without shapes needs bounds")
        cols = max(1, math.ceil((xmax - xmin) / res - 1e-9))
        rows = max(1, math.ceil((ymax - ymin) / res - 1e-9))
        heights = np.zeros((rows, cols), np.float32)
        for s in shapes:
            s.rasterise(heights, (xmin, ymin), res)
        start = parse_pose(spec["start"], source, "start") if "start" in spec else Pose2D()
        goals = _goals(spec.get("goals"), source)
        return cls(heights, res, (xmin, ymin), start, goals, str(spec.get("name", "")), shapes)

    @classmethod
    def from_map_yaml(cls, path: str | Path, params: WorldParams = WorldParams()) -> World:
        """A map_server map; occupied cells get ``map_obstacle_height`` (or the YAML's obstacle_height)."""
        path = Path(path)
        src = str(path)
        y = read_yaml(path)
        for k in ("image", "resolution", "origin"):
            if k not in y:
                raise ConfigError(src, k, "missing (map_server map YAML)")
        origin = y["origin"]
        if not (isinstance(origin, (list, tuple)) and len(origin) >= 2):
            raise ConfigError(src, "origin", f"expected [x, y, yaw], got {origin!r}")
        if len(origin) > 2 and abs(float(origin[2])) > 1e-9:
            raise ConfigError(src, "origin", "a rotated map origin is not supported")
        img_path = Path(str(y["image"]))
        if not img_path.is_absolute():
            img_path = path.parent / img_path
        try:
            img = read_pgm(img_path).astype(np.float64)
        except (OSError, ValueError) as e:
            raise ConfigError(src, "image", f"cannot read {img_path}: {e}") from e
        maxval = 255.0 if img.max(initial=0) <= 255 else 65535.0
        p = img / maxval if int(y.get("negate", 0)) else (maxval - img) / maxval
        occ_t, free_t = float(y.get("occupied_thresh", 0.65)), float(y.get("free_thresh", 0.196))
        occupied = p > occ_t
        if params.unknown_is_obstacle:
            occupied |= p >= free_t
        occupied = occupied[::-1]  # image row 0 is the top (highest y); ROS row 0 is the lowest y
        map_res = float(y["resolution"])
        h = float(y.get("obstacle_height", params.map_obstacle_height))
        x0, y0 = float(origin[0]), float(origin[1])
        res = params.resolution
        rows = max(1, round(occupied.shape[0] * map_res / res))
        cols = max(1, round(occupied.shape[1] * map_res / res))
        # nearest-neighbour resampling: each new cell takes the map cell under its centre
        iy = np.minimum(((np.arange(rows) + 0.5) * res / map_res).astype(np.int64), occupied.shape[0] - 1)
        ix = np.minimum(((np.arange(cols) + 0.5) * res / map_res).astype(np.int64), occupied.shape[1] - 1)
        heights = np.where(occupied[np.ix_(iy, ix)], np.float32(h), np.float32(0.0))
        if params.edge_walls:
            _close_edges(heights, (p >= free_t)[::-1][np.ix_(iy, ix)], np.float32(h))
        start = parse_pose(y["start"], src, "start") if "start" in y else Pose2D()
        return cls(heights, res, (x0, y0), start, _goals(y.get("goals"), src), path.stem)


def _close_edges(heights: np.ndarray, content: np.ndarray, h: np.float32) -> None:
    """``edge_walls``: the world ends where its map's content does — outside the bounding box of its
    occupied and unknown cells (``content``) everything is wall, and at the map's edge where the content
    reaches it. A map's free margin beyond its outer wall is the image's padding, not a place: MRPB's mall
    has 0.85 m of free floor all round outside its outer wall (118 m², a tenth of its floor), reached through
    the wall's openings, an alley the P3-AT, 0.83 m across its corners, cannot turn in: every contact of two
    exploration runs there (2026-11-29). The openings now end at a wall, as closed doors."""
    rows, cols = np.nonzero(content.any(axis=1))[0], np.nonzero(content.any(axis=0))[0]
    n, m = heights.shape
    r0, r1 = (int(rows[0]), int(rows[-1])) if len(rows) else (0, n - 1)
    c0, c1 = (int(cols[0]), int(cols[-1])) if len(cols) else (0, m - 1)
    heights[:max(r0, 1), :] = heights[min(r1, n - 2) + 1:, :] = h
    heights[:, :max(c0, 1)] = heights[:, min(c1, m - 2) + 1:] = h


def is_map_world(path: str | Path) -> bool:
    """Is ``path`` a map_server map YAML (not a world name or a shapes YAML)?"""
    p = Path(path)
    return p.suffix in (".yaml", ".yml") and p.is_file() and "image" in read_yaml(p)


def load_world(path: str | Path, params: WorldParams = WorldParams(), start: Any = None) -> World:
    """Load a shapes YAML or a map_server YAML (recognised by its ``image`` key); optional start override."""
    path = Path(path)
    spec = read_yaml(path)
    w = World.from_map_yaml(path, params) if "image" in spec else World.from_shapes(spec, params, str(path))
    if not w.name:
        w.name = path.stem
    return w.with_start(start) if start is not None else w

