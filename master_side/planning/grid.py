"""Costmap cost values and grid <-> world helpers shared by the planners.

Grid convention (ROS costmap_2d): ``grid[row, col]``, row 0 at ``origin_y`` (lowest y); cell (r, c)
has its centre at ``origin + ((c + 0.5) * res, (r + 0.5) * res)``.
"""

from __future__ import annotations

import math

import numpy as np

# costmap_2d cost_values.h (same numbers as master_side/costmap; repeated so planning has no import cycle)
FREE = 0
INSCRIBED = 253
LETHAL = 254
NO_INFORMATION = 255


def world_to_cell(x: float, y: float, resolution: float, origin_xy: tuple[float, float]) -> tuple[int, int]:
    """(row, col) of the cell containing world point (x, y); may lie outside the grid."""
    return (
        int(math.floor((y - origin_xy[1]) / resolution)),
        int(math.floor((x - origin_xy[0]) / resolution)),
    )


def world_to_grid(xy: np.ndarray, resolution: float, origin_xy: tuple[float, float]) -> np.ndarray:
    """Continuous grid coordinates (..., 2) as (col, row), integer values at cell centres."""
    xy = np.asarray(xy, dtype=float)
    return (xy - np.asarray(origin_xy[:2], dtype=float)) / resolution - 0.5


def grid_to_world(cr: np.ndarray, resolution: float, origin_xy: tuple[float, float]) -> np.ndarray:
    """Inverse of ``world_to_grid``: (col, row) grid coordinates to world (x, y)."""
    return (np.asarray(cr, dtype=float) + 0.5) * resolution + np.asarray(origin_xy[:2], dtype=float)


def in_grid(shape: tuple[int, int], row: int, col: int) -> bool:
    return 0 <= row < shape[0] and 0 <= col < shape[1]


def check_grid(grid: np.ndarray, resolution: float) -> np.ndarray:
    """Validate a costmap grid (2-D uint8, positive resolution); returns it as a uint8 array."""
    g = np.asarray(grid)
    if g.ndim != 2 or g.size == 0:
        raise ValueError(f"costmap grid must be a non-empty 2-D array, got shape {g.shape}")
    if g.dtype != np.uint8:
        raise ValueError(f"costmap grid must be uint8, got {g.dtype}")
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    return g
