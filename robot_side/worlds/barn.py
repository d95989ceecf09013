"""BARN (Benchmark for Autonomous Robot Navigation) worlds as simulator worlds. Pure: numpy only.

A BARN world is a field of unit cylinders (radius 0.075 m, 1 m tall) on the challenge's 0.15 m grid plus
a box of 96 cylinders behind and beside the start, so the robot cannot drive around the field; beyond
that the challenge's Gazebo world is an empty ground plane. Geometry and rules:
``../shared/datasets/barn/README.md`` (the challenge's ``run.py``, github Daffan/the-barn-challenge).

    spec = barn_world_spec(cylinders, name="barn_1")   # World.from_shapes(spec) / write_world_yaml(...)

Resolution: the simulator rasterises a shape by cell centres, so a cylinder's cells depend on where its
centre falls in a cell. ``RESOLUTION`` = 0.01 m divides the 0.15 m BARN pitch and the grid origin is
aligned so every cylinder centre is a cell centre: each cylinder gets the same 177 cells, 1.002 π r², and
the rasterised disc lies between r - 5 mm and r + 4 mm (a 0.02 m grid: 0.97-1.02 π r² depending on the
offset, up to r + 12 mm). Touching neighbours stay joined 5 cells thick (no laser leaks between them).
A 720-beam scan of a BARN world costs well under 1 ms (``python bench/sim.py``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = [
    "CYLINDER_RADIUS", "CYLINDER_HEIGHT", "GRID_PITCH", "START", "GOAL", "GOAL_IN_ODOM", "GOAL_YAW", "FIELD",
    "BOX_CYLINDERS", "RESOLUTION", "MARGIN", "barn_bounds", "barn_world_spec", "box_mask", "path_xy",
    "reference_path_length", "world_yaml_text", "write_world_yaml",
]

CYLINDER_RADIUS = 0.075          # m
CYLINDER_HEIGHT = 1.0            # m
GRID_PITCH = 0.15                # m, the BARN grid (30 x 30 cells)
START = (-2.25, 3.0, 1.57)       # x, y, yaw in the world frame (run.py INIT_POSITION)
GOAL = (-2.25, 13.0)             # world frame: 10 m straight ahead of the start
GOAL_IN_ODOM = (0.0, 10.0)       # as the challenge sends it, in a world-aligned odom frame
GOAL_YAW = 0.0                   # the challenge's goal orientation: identity quaternion (ignored by the rules)
FIELD = (-4.5, 5.1, 0.0, 9.6)    # xmin, ymin, xmax, ymax of the obstacle field
BOX_CYLINDERS = 96               # back wall (30) + two side walls (33 each), the same in every world
BOX_MAX_Y = 5.1                  # cylinders below the field belong to the box
RESOLUTION = 0.01                # m, see the module docstring
MARGIN = 2.0                     # m of free space around box, field, start and goal
# the lattice of cylinder centres: x = -4.425 + 0.15 r, y = 0.075 + 0.15 k (box) = 5.175 + 0.15 c (field)
_LATTICE = (-4.425, 0.075)
# a reference path cell (r, c) of the 30 x 30 grid -> world: x = 0.15 r - 4.575, y = 0.15 c + 5.075
_PATH_ORIGIN = (-4.575, 5.075)


def _as_xy(cylinders: np.ndarray) -> np.ndarray:
    c = np.asarray(cylinders, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 2:
        raise ValueError(f"cylinders must be a (K, 2) array of centres, got shape {c.shape}")
    return c


def box_mask(cylinders: np.ndarray) -> np.ndarray:
    """True for the cylinders of the containment box (everything below the field)."""
    return _as_xy(cylinders)[:, 1] < BOX_MAX_Y


def barn_bounds(cylinders: np.ndarray | None = None, resolution: float = RESOLUTION,
                margin: float = MARGIN) -> list[float]:
    """[xmin, ymin, xmax, ymax] holding the box, field, start, goal (and ``cylinders``) with ``margin``.

    When the 0.15 m pitch is a whole number of cells, the origin is moved down so that every cylinder
    centre is a cell centre: all cylinders then rasterise identically (and symmetrically)."""
    xs = [FIELD[0], FIELD[2], START[0], GOAL[0]]
    ys = [0.0, FIELD[3], START[1], GOAL[1]]
    if cylinders is not None and len(cylinders):
        c = _as_xy(cylinders)
        xs += [c[:, 0].min() - CYLINDER_RADIUS, c[:, 0].max() + CYLINDER_RADIUS]
        ys += [c[:, 1].min() - CYLINDER_RADIUS, c[:, 1].max() + CYLINDER_RADIUS]
    lo = [min(xs) - margin, min(ys) - margin]
    hi = [max(xs) + margin, max(ys) + margin]
    if abs(GRID_PITCH / resolution - round(GRID_PITCH / resolution)) < 1e-9:
        for i in (0, 1):
            k = math.ceil((_LATTICE[i] - lo[i]) / resolution - 0.5 - 1e-9)
            lo[i] = round(_LATTICE[i] - (k + 0.5) * resolution, 9)
    return [lo[0], lo[1], round(hi[0], 9), round(hi[1], 9)]


def barn_world_spec(cylinders: np.ndarray, name: str = "barn", resolution: float = RESOLUTION,
                    margin: float = MARGIN) -> dict:
    """A shapes-YAML world spec (``World.from_shapes``) of one BARN world: bounds, resolution, start,
    the goal, and one cylinder per centre (float32 noise of the dataset rounded to 0.1 mm)."""
    c = np.round(_as_xy(cylinders), 4)
    return {
        "name": name,
        "bounds": barn_bounds(c, resolution, margin),
        "resolution": float(resolution),
        "start": [START[0], START[1], START[2]],
        "goals": {"goal": [GOAL[0], GOAL[1], GOAL_YAW]},
        "cylinders": [{"center": [float(x), float(y)], "radius": CYLINDER_RADIUS, "height": CYLINDER_HEIGHT}
                      for x, y in c],
    }


def path_xy(cells: np.ndarray) -> np.ndarray:
    """World (x, y) of reference path cells (r, c) of the 30 x 30 BARN grid."""
    rc = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return np.column_stack((_PATH_ORIGIN[0] + GRID_PITCH * rc[:, 0], _PATH_ORIGIN[1] + GRID_PITCH * rc[:, 1]))


def reference_path_length(cells: np.ndarray) -> float:
    """L: |start -> first cell| + polyline through the cells + |last cell -> goal| (metres)."""
    pts = np.vstack((START[:2], path_xy(cells), GOAL))
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def _num(v: float) -> str:
    return f"{v:.6g}" if abs(v) >= 1e-4 or v == 0 else f"{v:.6e}"


def world_yaml_text(spec: dict, comment: str = "") -> str:
    """The spec as a shapes YAML (one flow-style line per cylinder); ``comment`` lines lead the file."""
    lines = [f"# {line}".rstrip() for line in comment.splitlines()]
    lines.append(f"name: {spec['name']}")
    lines.append(f"bounds: [{', '.join(_num(v) for v in spec['bounds'])}]")
    lines.append(f"resolution: {_num(spec['resolution'])}")
    lines.append(f"start: [{', '.join(_num(v) for v in spec['start'])}]")
    lines.append("goals:")
    for k, g in spec.get("goals", {}).items():
        lines.append(f"  {k}: [{', '.join(_num(v) for v in g)}]")
    lines.append("cylinders:")
    for cyl in spec["cylinders"]:
        x, y = cyl["center"]
        lines.append(f"  - {{center: [{_num(x)}, {_num(y)}], radius: {_num(cyl['radius'])}, "
                     f"height: {_num(cyl['height'])}}}")
    return "\n".join(lines) + "\n"


def write_world_yaml(spec: dict, path: str | Path, comment: str = "") -> Path:
    """Write ``spec`` (from ``barn_world_spec``) as a world YAML file; returns its path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(world_yaml_text(spec, comment))
    return path
