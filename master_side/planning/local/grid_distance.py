"""base_local_planner's MapGrid: distances to the plan and to the local goal by flood fill (pure).

ROS's local planners score a trajectory by how many cells separate its end point from the global
plan (path distance) and from the local goal (goal distance), counted by a breadth-first flood fill
over the local costmap: 4-connected steps (a Manhattan count) that go around obstacles. A cell that
is LETHAL, INSCRIBED or NO_INFORMATION stops the fill (unless it lies under the robot's current
footprint); such a cell, and any cell the fill never reaches, is *impossible*: a trajectory that
passes through one is rejected, so the planner never heads into a pocket that has no way to the plan.

Here the fill is one ``scipy.sparse.csgraph.breadth_first_order`` from a virtual source joined to
the target cells, on a 4-neighbour graph whose blocked cells have no way out. Depths
come from the BFS order (parents are dequeued in order, so each level is a contiguous run).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from master_side.planning.grid import INSCRIBED, NO_INFORMATION

IMPOSSIBLE = np.inf  # distance of an obstacle or unreachable cell (ROS: size of the map, or that + 1)


class _Lattice:
    """The 4-neighbour CSR structure of an H x W grid (rows = cells; node H*W is the dead end)."""

    def __init__(self, shape: tuple[int, int]):
        h, w = shape
        n = h * w
        idx = np.arange(n).reshape(h, w)
        src, dst = [], []
        for a, b in ((idx[:, :-1], idx[:, 1:]), (idx[:, 1:], idx[:, :-1]), (idx[:-1, :], idx[1:, :]),
                     (idx[1:, :], idx[:-1, :])):
            src.append(a.ravel())
            dst.append(b.ravel())
        src, dst = np.concatenate(src), np.concatenate(dst)
        order = np.argsort(src, kind="stable")
        self.shape, self.n = shape, n
        self.dst = dst[order].astype(np.int32)
        counts = np.bincount(src, minlength=n)
        # rows: cells 0..n-1, the dead end n (no edges), the virtual source n+1 (edges appended per fill)
        self.indptr = np.concatenate(([0], np.cumsum(counts), [len(dst), len(dst)])).astype(np.int32)
        # positions in ``dst`` of each cell's out-edges, padded with len(dst) (a spare slot)
        k = np.arange(4)[None, :]
        out = self.indptr[:n, None] + k
        self.out_edges = np.where(k < counts[:, None], out, len(dst)).astype(np.int64)
        self._data = np.ones(0)

    def _ones(self, k: int) -> np.ndarray:
        if len(self._data) < k:
            self._data = np.ones(2 * k)
        return self._data[:k]

    def fill(self, passable: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """BFS depth (cells) of every cell from the nearest target; IMPOSSIBLE where not reached.

        ``passable`` (n,) bool: cells the fill may enter; ``targets`` flat indices (depth 0; they are
        expanded even when not passable, as ROS expands every plan cell it marks).
        """
        n = self.n
        out = np.full(n, IMPOSSIBLE)
        targets = np.unique(np.asarray(targets, np.int64))
        if targets.size == 0:
            return out.reshape(self.shape)
        # Blocked cells are reached but expand nothing (their out-edges lead to the dead end); their
        # depth is overwritten with IMPOSSIBLE below. Targets expand even when blocked.
        blocked = ~passable
        blocked[targets] = False
        ind = np.empty(len(self.dst) + 1, np.int32)
        ind[:-1] = self.dst
        ind[self.out_edges[blocked]] = n
        ind = ind[:-1]
        indptr = self.indptr.copy()
        indptr[-1] = len(ind) + len(targets)
        graph = csr_matrix((self._ones(indptr[-1]), np.concatenate((ind, targets.astype(np.int32))), indptr),
                           shape=(n + 2, n + 2))
        graph.has_sorted_indices = True  # order and duplicates do not matter to a BFS: skip canonicalising
        order, pred = breadth_first_order(graph, n + 1, directed=True, return_predecessors=True)
        order = order[1:]  # drop the virtual source
        order = order[order != n]
        m = len(order)
        pos = np.empty(n + 2, np.int64)
        pos[n + 1] = -1
        pos[order] = np.arange(m)
        # BFS order is by depth, and the parents' positions never decrease along it, so level k + 1
        # is the run of nodes whose parents lie in level k: below(j) = how many nodes have a parent
        # before position j, and the level boundaries are its iterates from 0.
        below = np.cumsum(np.bincount(pos[pred[order]] + 1, minlength=m + 1))
        bounds = [0]
        while bounds[-1] < m:
            bounds.append(max(int(below[bounds[-1]]), bounds[-1] + 1))
        depth = np.repeat(np.arange(len(bounds) - 1, dtype=np.float64), np.diff(bounds))
        out[order] = depth
        out[blocked] = IMPOSSIBLE
        return out.reshape(self.shape)


_LATTICES: dict[tuple[int, int], _Lattice] = {}


def lattice(shape: tuple[int, int]) -> _Lattice:
    if shape not in _LATTICES:
        if len(_LATTICES) > 8:
            _LATTICES.clear()
        _LATTICES[shape] = _Lattice(shape)
    return _LATTICES[shape]


def densify(xy: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points along a polyline so consecutive points are at most ``spacing`` apart (with one
    cell as spacing: MapGrid::adjustPlanResolution)."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    if len(xy) < 2:
        return xy
    seg = np.diff(xy, axis=0)
    n = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / spacing).astype(int), 1)
    i = np.repeat(np.arange(len(seg)), n)
    t = np.arange(len(i)) - np.repeat(np.cumsum(n) - n, n)  # 0..n_k-1 within each segment
    return np.vstack((xy[i] + seg[i] * (t / n[i])[:, None], xy[-1:]))


def plan_cells(grid: np.ndarray, resolution: float, origin: np.ndarray, plan_xy: np.ndarray) -> np.ndarray:
    """Flat indices of the plan's cells from where it enters the map (on a known cell) until it
    first leaves it (MapGrid::setTargetCells); empty if it never enters."""
    h, w = grid.shape
    pts = densify(plan_xy, resolution)
    c = np.floor((pts[:, 0] - origin[0]) / resolution).astype(np.int64)
    r = np.floor((pts[:, 1] - origin[1]) / resolution).astype(np.int64)
    inside = (c >= 0) & (c < w) & (r >= 0) & (r < h)
    ok = inside.copy()
    ok[inside] = grid[r[inside], c[inside]] != NO_INFORMATION
    if not ok.any():
        return np.zeros(0, np.int64)
    first = int(np.argmax(ok))
    out = np.flatnonzero(~ok[first:])
    end = first + (int(out[0]) if out.size else len(ok) - first)
    return r[first:end] * w + c[first:end]


class MapGrid:
    """Path and local-goal distance maps (cells) over one local costmap, as base_local_planner does.

    ``within_robot``: optional (H, W) bool of the cells under the current footprint (passable even
    when inscribed; TrajectoryPlanner marks them, DWA does not).
    """

    def __init__(self, grid: np.ndarray, resolution: float, origin, within_robot: np.ndarray | None = None):
        self.grid, self.resolution = grid, float(resolution)
        self.origin = np.asarray(origin, float)[:2]
        self.lattice = lattice(grid.shape)
        passable = grid < INSCRIBED
        if within_robot is not None:
            passable = passable | within_robot
        self.passable = passable.ravel()

    def path_distance(self, plan_xy: np.ndarray) -> np.ndarray:
        """Cells to the nearest plan cell (the plan cut where it leaves the map)."""
        return self.lattice.fill(self.passable, plan_cells(self.grid, self.resolution, self.origin, plan_xy))

    def local_goal_cell(self, plan_xy: np.ndarray) -> int | None:
        """Flat index of the last plan cell before the plan first leaves the map (setLocalGoal)."""
        cells = plan_cells(self.grid, self.resolution, self.origin, plan_xy)
        return int(cells[-1]) if cells.size else None

    def goal_distance(self, plan_xy: np.ndarray) -> np.ndarray:
        """Cells to the local goal."""
        cell = self.local_goal_cell(plan_xy)
        targets = np.zeros(0, np.int64) if cell is None else np.array([cell])
        return self.lattice.fill(self.passable, targets)

    def goal_xy(self, plan_xy: np.ndarray) -> np.ndarray | None:
        """World coordinates of the local goal cell's centre."""
        cell = self.local_goal_cell(plan_xy)
        if cell is None:
            return None
        r, c = divmod(cell, self.grid.shape[1])
        return self.origin + (np.array([c, r]) + 0.5) * self.resolution
