"""Frontier search on a costmap, as explore_lite defines it (our code).

A frontier cell is an unknown cell (NO_INFORMATION) next to (4-connected) free space the robot can
reach: the cells below INSCRIBED connected (4-connected) to the robot's cell, or to the free cell
nearest it when the robot stands on a costly one. Frontier cells are grouped 8-connected into frontiers;
each has its size (cells), centroid, and the cell nearest the robot (``middle``, at ``min_distance``).
The place to send the robot (``goal``) is the centroid, as explore_lite sends it, unless it falls where
the robot's centre cannot be (a curved frontier's centroid can lie in a wall or a crate, and move_base
refuses such a goal): then the reachable cell beside the frontier cell nearest the centroid.
Frontiers smaller than ``min_frontier_size`` metres are dropped. The cost is explore_lite's:
``potential_scale * min_distance - gain_scale * size``, both in metres here (explore_lite multiplies its
metric distance by the resolution once more), cheapest first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from master_side.costmap.cost_values import FREE, INSCRIBED, LETHAL, NO_INFORMATION

_FOUR = ndimage.generate_binary_structure(2, 1)
_EIGHT = ndimage.generate_binary_structure(2, 2)


@dataclass(frozen=True)
class Frontier:
    size: int  # cells
    size_m: float  # size x resolution, as explore_lite measures it
    centroid: tuple[float, float]  # world frame of the grid
    middle: tuple[float, float]  # the frontier cell nearest the robot
    min_distance: float  # m, from the robot to ``middle``
    cost: float
    cells: np.ndarray  # (n, 2) world x, y of every cell
    goal: tuple[float, float]  # where to send the robot: the centroid, or the reachable cell nearest it


@dataclass(frozen=True)
class Grid:
    """A costmap's cells (uint8, rows = y) and where they lie."""
    data: np.ndarray
    resolution: float
    origin: tuple[float, float]

    def cell(self, x: float, y: float) -> tuple[int, int] | None:
        c = int(np.floor((x - self.origin[0]) / self.resolution))
        r = int(np.floor((y - self.origin[1]) / self.resolution))
        h, w = self.data.shape
        return (r, c) if 0 <= r < h and 0 <= c < w else None

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        return np.column_stack((self.origin[0] + (cols + 0.5) * self.resolution,
                                self.origin[1] + (rows + 0.5) * self.resolution))


def grid_from_map(data: np.ndarray, resolution: float, origin: tuple[float, float],
                  inscribed_radius: float, occupied: int = 65) -> Grid:
    """A SLAM map (OccupancyGrid values: -1 unknown, 0..100) as costs: unknown, LETHAL from ``occupied``,
    INSCRIBED within ``inscribed_radius`` of a LETHAL cell (where the robot's centre cannot go), else FREE."""
    data = np.asarray(data)
    lethal = data >= occupied
    cost = np.where(data < 0, NO_INFORMATION, FREE).astype(np.uint8)
    if lethal.any():
        near = ndimage.distance_transform_edt(~lethal) * resolution <= inscribed_radius
        cost[near & (data >= 0)] = INSCRIBED
    cost[lethal] = LETHAL
    return Grid(cost, resolution, origin)


def reachable(grid: Grid, robot: tuple[float, float]) -> np.ndarray:
    """Free cells (cost below INSCRIBED) 4-connected to the robot's cell, or to the free cell nearest it."""
    free = grid.data < INSCRIBED
    at = grid.cell(*robot)
    if at is None:
        raise ValueError(f"the robot at ({robot[0]:.2f}, {robot[1]:.2f}) is outside the costmap")
    if not free[at]:
        rr, cc = np.nonzero(free)
        if len(rr) == 0:
            return np.zeros_like(free)
        k = int(np.argmin((rr - at[0]) ** 2 + (cc - at[1]) ** 2))
        at = (int(rr[k]), int(cc[k]))
    labels, _ = ndimage.label(free, structure=_FOUR)
    return labels == labels[at]


def _goal(grid: Grid, reach: np.ndarray, rows: np.ndarray, cols: np.ndarray,
          centroid: tuple[float, float]) -> tuple[float, float]:
    """The centroid unless its cell is INSCRIBED or LETHAL (unknown is allowed: move_base plans into it),
    else the reachable neighbour of the frontier cell nearest the centroid (every frontier cell has one)."""
    at = grid.cell(*centroid)
    if at is not None and (grid.data[at] < INSCRIBED or grid.data[at] == NO_INFORMATION):
        return float(centroid[0]), float(centroid[1])
    xy = grid.centres(rows, cols)
    k = int(np.argmin(np.hypot(xy[:, 0] - centroid[0], xy[:, 1] - centroid[1])))
    r, c = int(rows[k]), int(cols[k])
    h, w = reach.shape
    for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
        if 0 <= rr < h and 0 <= cc < w and reach[rr, cc]:
            x, y = grid.centres(np.array([rr]), np.array([cc]))[0]
            return float(x), float(y)
    return float(centroid[0]), float(centroid[1])  # not reached: a frontier cell borders reachable space


def search(grid: Grid, robot: tuple[float, float], potential_scale: float = 1e-3, gain_scale: float = 1.0,
           min_frontier_size: float = 0.5) -> list[Frontier]:
    """The frontiers reachable from ``robot`` (x, y in the grid's frame), cheapest first."""
    reach = reachable(grid, robot)
    unknown = grid.data == NO_INFORMATION
    frontier = unknown & ndimage.binary_dilation(reach, structure=_FOUR)
    labels, n = ndimage.label(frontier, structure=_EIGHT)
    if n == 0:
        return []
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    xy = grid.centres(rows, cols)
    d = np.hypot(xy[:, 0] - robot[0], xy[:, 1] - robot[1])
    out = []
    order = np.argsort(ids, kind="stable")
    bounds = np.searchsorted(ids[order], np.arange(1, n + 2))
    for k in range(n):
        idx = order[bounds[k]:bounds[k + 1]]
        size_m = len(idx) * grid.resolution
        if size_m < min_frontier_size:
            continue
        near = idx[int(np.argmin(d[idx]))]
        cost = potential_scale * float(d[near]) - gain_scale * size_m
        cx, cy = xy[idx].mean(axis=0)
        out.append(Frontier(len(idx), size_m, (float(cx), float(cy)), (float(xy[near, 0]), float(xy[near, 1])),
                            float(d[near]), cost, xy[idx], _goal(grid, reach, rows[idx], cols[idx], (cx, cy))))
    out.sort(key=lambda f: f.cost)
    return out
