"""The local goal cell of a plan whose last pose moves every cycle (DWA's goal-front plan).

``MapGrid.local_goal_cell`` densifies the whole plan and walks its cells each time. DWA pushes only the
plan's last pose (along the robot -> goal direction, so it moves with the robot): here the cells of
every other segment are summarised once per plan and costmap, and each cycle only the last segment is
densified. Same points (``densify`` works segment by segment), same cells, same answer.
"""

from __future__ import annotations

import numpy as np

from master_side.planning.grid import NO_INFORMATION
from master_side.planning.local.grid_distance import densify

_PREFIXES: dict = {}  # (prefix, costmap) -> summary, the last few


def _cells_ok(grid: np.ndarray, resolution: float, origin: np.ndarray, pts: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """(flat cells, on the map and known) of points, as ``plan_cells`` computes them."""
    h, w = grid.shape
    c = np.floor((pts[:, 0] - origin[0]) / resolution).astype(np.int64)
    r = np.floor((pts[:, 1] - origin[1]) / resolution).astype(np.int64)
    inside = (c >= 0) & (c < w) & (r >= 0) & (r < h)
    ok = inside.copy()
    ok[inside] = grid[r[inside], c[inside]] != NO_INFORMATION
    return r * w + c, ok


def _summary(cells: np.ndarray, ok: np.ndarray, start_in_run: bool = False) -> tuple[bool, bool, int]:
    """(a run of good cells started, it ended before the last point, its last cell) of a point sequence;
    ``start_in_run``: the run began before this sequence (it then starts at index 0 if that is good)."""
    if start_in_run:
        first = 0
        if ok.size == 0 or not ok[0]:
            return True, True, -1  # ended right at the boundary: the caller keeps its own last cell
    elif not ok.any():
        return False, False, -1
    else:
        first = int(np.argmax(ok))
    out = np.flatnonzero(~ok[first:])
    end = first + (int(out[0]) if out.size else len(ok) - first)
    return True, bool(out.size), int(cells[end - 1])


def pushed_goal_cell(grid: np.ndarray, resolution: float, origin: np.ndarray, plan_xy: np.ndarray,
                     end_xy: np.ndarray) -> int | None:
    """``MapGrid.local_goal_cell`` of ``plan_xy`` (N, 2) with its last point replaced by ``end_xy``."""
    origin = np.asarray(origin, float)[:2]
    if len(plan_xy) < 2:
        cells, ok = _cells_ok(grid, resolution, origin, np.asarray(end_xy, float).reshape(1, 2))
        return int(cells[0]) if ok[0] else None
    key = (plan_xy[:-1].tobytes(), grid.tobytes(), grid.shape, float(resolution), origin.tobytes())
    pre = _PREFIXES.get(key)
    if pre is None:
        pts = densify(plan_xy[:-1], resolution)[:-1]  # every segment but the last, without its end
        pre = _summary(*_cells_ok(grid, resolution, origin, pts))
        if len(_PREFIXES) >= 8:
            _PREFIXES.pop(next(iter(_PREFIXES)))
        _PREFIXES[key] = pre
    started, ended, last = pre
    if started and ended:
        return last
    tail = densify(np.vstack((plan_xy[-2], end_xy)), resolution)
    got, _, tail_last = _summary(*_cells_ok(grid, resolution, origin, tail), start_in_run=started)
    if started:
        return last if tail_last < 0 else tail_last
    return tail_last if got else None
