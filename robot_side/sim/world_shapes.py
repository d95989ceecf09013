"""The shapes of a simulated world's YAML (walls, boxes, cylinders), parsed and checked, and how each
is rasterised into the height grid (a cell takes the tallest shape covering its centre)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from common.config import ConfigError


@dataclass(frozen=True)
class Box:
    """A box of ``height`` centred at (cx, cy), sides sx by sy, turned by ``yaw`` (walls are boxes too)."""

    cx: float
    cy: float
    sx: float
    sy: float
    yaw: float
    height: float
    movable: bool = False   # the MuJoCo engine: a free body of ``mass`` the robot can push
    mass: float = 0.0       # kg (movable boxes only)

    def extent(self) -> tuple[float, float, float, float]:
        c, s = abs(math.cos(self.yaw)), abs(math.sin(self.yaw))
        hx, hy = (c * self.sx + s * self.sy) / 2, (s * self.sx + c * self.sy) / 2
        return self.cx - hx, self.cy - hy, self.cx + hx, self.cy + hy

    def inside(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = x - self.cx, y - self.cy
        u, v = c * dx + s * dy, -s * dx + c * dy
        return (np.abs(u) <= self.sx / 2) & (np.abs(v) <= self.sy / 2)

    def rasterise(self, grid: np.ndarray, origin: tuple[float, float], res: float) -> None:
        xmin, ymin, xmax, ymax = self.extent()
        i0 = max(0, math.floor((xmin - origin[0]) / res) - 1)
        i1 = min(grid.shape[1], math.ceil((xmax - origin[0]) / res) + 1)
        j0 = max(0, math.floor((ymin - origin[1]) / res) - 1)
        j1 = min(grid.shape[0], math.ceil((ymax - origin[1]) / res) + 1)
        if i0 >= i1 or j0 >= j1:
            return
        xs = origin[0] + (np.arange(i0, i1) + 0.5) * res
        ys = origin[1] + (np.arange(j0, j1) + 0.5) * res
        mask = self.inside(xs[None, :], ys[:, None])
        sub = grid[j0:j1, i0:i1]
        np.maximum(sub, np.where(mask, np.float32(self.height), np.float32(0.0)), out=sub)


@dataclass(frozen=True)
class Cylinder(Box):
    """An upright cylinder: diameter ``sx`` (= ``sy``), ``yaw`` unused."""

    def inside(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return (x - self.cx) ** 2 + (y - self.cy) ** 2 <= (self.sx / 2) ** 2


def _num(d: dict, key: str, source: str, where: str, default: float | None = None, n: int = 0) -> Any:
    if key not in d:
        if default is None:
            raise ConfigError(source, f"{where}.{key}", "missing")
        return default
    v = d[key]
    try:
        if n:
            if not isinstance(v, (list, tuple)) or len(v) != n:
                raise TypeError
            return tuple(float(a) for a in v)
        if isinstance(v, bool):
            raise TypeError
        return float(v)
    except (TypeError, ValueError) as e:
        raise ConfigError(source, f"{where}.{key}", f"expected {n or 1} number(s), got {v!r}") from e


def parse_shapes(spec: dict, source: str) -> list[Box]:
    """The ``walls``, ``boxes`` and ``cylinders`` of a shapes YAML, each checked (ConfigError)."""
    out: list[Box] = []
    keys = {"walls": {"from", "to", "thickness", "height"},
            "boxes": {"center", "size", "yaw", "height", "movable", "mass"},
            "cylinders": {"center", "radius", "height"}}
    for kind, allowed in keys.items():
        items = spec.get(kind) or []
        if not isinstance(items, list):
            raise ConfigError(source, kind, "expected a list")
        for i, d in enumerate(items):
            where = f"{kind}[{i}]"
            if not isinstance(d, dict):
                raise ConfigError(source, where, "expected a mapping")
            for k in d:
                if k not in allowed:
                    known = ", ".join(sorted(allowed))
                    raise ConfigError(source, f"{where}.{k}", f"unknown key (known keys: {known})")
            h = _num(d, "height", source, where, 2.0 if kind == "walls" else None)
            if h <= 0:
                raise ConfigError(source, f"{where}.height", "must be > 0")
            if kind == "walls":
                (ax, ay), (bx, by) = _num(d, "from", source, where, n=2), _num(d, "to", source, where, n=2)
                t = _num(d, "thickness", source, where, 0.1)
                length = math.hypot(bx - ax, by - ay)
                out.append(Box((ax + bx) / 2, (ay + by) / 2, length + t, t, math.atan2(by - ay, bx - ax), h))
            elif kind == "boxes":
                cx, cy = _num(d, "center", source, where, n=2)
                sx, sy = _num(d, "size", source, where, n=2)
                if sx <= 0 or sy <= 0:
                    raise ConfigError(source, f"{where}.size", "must be > 0")
                movable = d.get("movable", False)
                if not isinstance(movable, bool):
                    raise ConfigError(source, f"{where}.movable", f"expected true or false, got {movable!r}")
                mass = _num(d, "mass", source, where, 0.0)
                if movable and mass <= 0:
                    raise ConfigError(source, f"{where}.mass", "a movable box needs a mass > 0 (kg)")
                out.append(Box(cx, cy, sx, sy, _num(d, "yaw", source, where, 0.0), h, movable, mass))
            else:
                cx, cy = _num(d, "center", source, where, n=2)
                r = _num(d, "radius", source, where)
                if r <= 0:
                    raise ConfigError(source, f"{where}.radius", "must be > 0")
                out.append(Cylinder(cx, cy, 2 * r, 2 * r, 0.0, h))
    return out


def grid_boxes(heights: np.ndarray, origin: tuple[float, float], res: float) -> list[Box]:
    """Axis-aligned boxes covering the obstacle cells of a height grid: runs of equal height along each
    row, merged with the identical runs of the rows above (a map's walls become a few long boxes)."""
    out: list[Box] = []
    open_runs: dict[tuple[int, int, float], int] = {}  # (col0, col1, height) -> first row
    for r in range(heights.shape[0] + 1):
        runs = set()
        if r < heights.shape[0]:
            row = heights[r]
            edges = np.flatnonzero(np.diff(np.concatenate(([0.0], row, [0.0]))) != 0)
            for a, b in zip(edges[:-1], edges[1:]):
                if row[a] > 0:
                    runs.add((int(a), int(b), float(row[a])))
        for key in [k for k in open_runs if k not in runs]:
            r0 = open_runs.pop(key)
            c0, c1, h = key
            out.append(Box(origin[0] + (c0 + c1) * res / 2, origin[1] + (r0 + r) * res / 2, (c1 - c0) * res,
                           (r - r0) * res, 0.0, h))
        for key in runs:
            open_runs.setdefault(key, r)
    return out
