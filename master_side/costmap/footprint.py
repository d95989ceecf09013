"""Robot footprint (costmap_2d/footprint.h): polygon or robot_radius, padding, radii, transforms.

A footprint is an (N, 2) float array of (x, y) in the robot base frame, N >= 3.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import yaml

from common.geometry import Pose2D

CIRCLE_POINTS = 16  # costmap_2d makeFootprintFromRadius uses 16 vertices


def make_footprint_from_radius(radius: float, n: int = CIRCLE_POINTS) -> np.ndarray:
    a = np.arange(n) * (2.0 * math.pi / n)
    return np.column_stack((radius * np.cos(a), radius * np.sin(a)))


def parse_footprint(value: Any) -> np.ndarray:
    """A footprint from a list of [x, y] pairs or the ROS string form "[[x, y], [x, y], ...]".

    An empty list / "[]" gives an empty (0, 2) array (meaning: use robot_radius).
    Raises ValueError when the value is not a list of at least 3 numeric pairs.
    """
    if isinstance(value, str):
        try:
            value = yaml.safe_load(value) if value.strip() else []
        except yaml.YAMLError as e:
            raise ValueError(f"footprint string {value!r} is not a list of [x, y] points") from e
    if value is None:
        value = []
    if not isinstance(value, (list, tuple, np.ndarray)):
        raise ValueError(f"footprint must be a list of [x, y] points, got {value!r}")
    if len(value) == 0:
        return np.zeros((0, 2))
    pts = []
    for p in value:
        if (not isinstance(p, (list, tuple, np.ndarray)) or len(p) != 2
                or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in p)):
            raise ValueError(f"footprint point {p!r} is not a pair of numbers [x, y]")
        pts.append((float(p[0]), float(p[1])))
    if len(pts) < 3:
        raise ValueError(f"footprint needs at least 3 points, got {len(pts)}")
    arr = np.array(pts)
    if not np.all(np.isfinite(arr)):
        raise ValueError("footprint points must be finite")
    return arr


def pad_footprint(footprint: np.ndarray, padding: float) -> np.ndarray:
    """costmap_2d padFootprint: every coordinate moves away from 0 by ``padding`` (per axis)."""
    fp = np.asarray(footprint, float)
    return fp + np.sign(fp) * padding


def footprint_from_params(footprint: Any, robot_radius: float, padding: float) -> np.ndarray:
    """ROS precedence: a valid ``footprint`` wins, else a circle of ``robot_radius``; then padding."""
    fp = parse_footprint(footprint)
    if len(fp) == 0:
        fp = make_footprint_from_radius(robot_radius)
    return pad_footprint(fp, padding)


def transform_footprint(footprint: np.ndarray, pose: Pose2D) -> np.ndarray:
    """The footprint placed at ``pose`` (global frame)."""
    return pose.apply(np.asarray(footprint, float))
