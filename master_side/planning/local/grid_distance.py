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

RECENT = 4  # fill results kept per grid shape
IMPOSSIBLE = np.inf  # distance of an obstacle or unreachable cell (ROS: size of the map, or that + 1)


class _Lattice:
    """The 4-neighbour CSR structure of an H x W grid (rows = cells; node H*W is the dead end)."""

    def __init__(self, shape: tuple[int, int]):
        h, w = shape
        n = h * w
        idx = np.arange(n).reshape(h, w)
        srcs: list[np.ndarray] = []
        dsts: list[np.ndarray] = []
        for a, b in ((idx[:, :-1], idx[:, 1:]), (idx[:, 1:], idx[:, :-1]), (idx[:-1, :], idx[1:, :]),
                     (idx[1:, :], idx[:-1, :])):
            srcs.append(a.ravel())
            dsts.append(b.ravel())
        src, dst = np.concatenate(srcs), np.concatenate(dsts)
        order = np.argsort(src, kind="stable")
        self.shape, self.n = shape, n
        self.dst = dst[order].astype(np.int32)
        counts = np.bincount(src, minlength=n)
        self.indptr = np.concatenate(([0], np.cumsum(counts))).astype(np.int32)  # rows of the n cells
        # positions in ``dst`` of each cell's out-edges, padded with len(dst) (a spare slot)
        k = np.arange(4)[None, :]
        out = self.indptr[:n, None] + k
        self.out_edges = np.where(k < counts[:, None], out, len(dst)).astype(np.int64)
        self._data = np.ones(0)
        self._recent: dict = {}

    def _ones(self, k: int) -> np.ndarray:
        if len(self._data) < k:
            self._data = np.ones(2 * k)
        return self._data[:k]

    def fill(self, passable: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """BFS depth (cells) of every cell from the nearest target; IMPOSSIBLE where not reached.

        ``passable`` (n,) bool: cells the fill may enter; ``targets`` flat indices (depth 0; they are
        expanded even when not passable, as ROS expands every plan cell it marks).
        """
        return self.fill_many(passable, [targets])[0]

    def fill_many(self, passable: np.ndarray, target_sets: list[np.ndarray]) -> list[np.ndarray]:
        """``fill`` for several target sets on the same grid: one graph, one virtual source per set (a graph
        per set when a set has targets the fill may not enter: those open for their own set only).

        The last few results are kept (read-only) and handed out again for the same passable cells and
        target sets: the costmap and the plan usually change less often than the planner runs."""
        sets = [np.unique(np.asarray(t, np.int64)) for t in target_sets]
        key = (passable.tobytes(), tuple(t.tobytes() for t in sets))
        got = self._recent.get(key)
        if got is None:
            got = self._fill_many(passable, sets)
            for a in got:
                a.flags.writeable = False
            if len(self._recent) >= RECENT:
                self._recent.pop(next(iter(self._recent), None), None)
        else:
            self._recent.pop(key, None)  # most recently used last
        self._recent[key] = got
        return list(got)

    def _fill_many(self, passable: np.ndarray, sets: list[np.ndarray]) -> list[np.ndarray]:
        if len(sets) > 1 and any(not passable[t].all() for t in sets):
            # a set's blocked targets expand for that set only: opened for all, the plan's cells where the
            # plan crosses a wall on the local costmap let the local goal's fill through the wall
            return [self._fill_many(passable, [t])[0] for t in sets]
        n, k = self.n, len(sets)
        # Blocked cells are reached but expand nothing (their out-edges lead to the dead end n); their
        # depth is overwritten with IMPOSSIBLE below. Targets expand even when blocked.
        blocked = ~passable
        for t in sets:
            blocked[t] = False
        m = len(self.dst)
        ind = np.empty(m + 1 + sum(len(t) for t in sets), np.int32)
        ind[:m] = self.dst
        ind[m] = n  # the spare slot the padding of out_edges points at
        ind[self.out_edges[blocked]] = n
        ends = m + 1 + np.cumsum([len(t) for t in sets])
        ind[m + 1:] = np.concatenate(sets) if sets else []
        # rows: cells 0..n-1, dead end n (no edges), virtual source n + 1 + i for target set i
        indptr = np.concatenate((self.indptr[:n + 1], [m + 1], ends)).astype(np.int32)
        graph = csr_matrix((self._ones(len(ind)), ind, indptr), shape=(n + 1 + k, n + 1 + k))
        graph.has_sorted_indices = True  # order and duplicates do not matter to a BFS: skip canonicalising
        outs = []
        for i, targets in enumerate(sets):
            out = np.full(n, IMPOSSIBLE)
            if targets.size:
                order, depth = _depths(graph, n, n + 1 + i)
                out[order] = depth
                out[blocked] = IMPOSSIBLE
            outs.append(out.reshape(self.shape))
        return outs


def _depths(graph, n: int, source: int) -> tuple[np.ndarray, np.ndarray]:
    """(cells reached, their BFS depth from the virtual ``source``'s targets) on ``graph``."""
    order, pred = breadth_first_order(graph, source, directed=True, return_predecessors=True)
    order = order[1:]  # drop the virtual source
    order = order[order != n]  # and the dead end
    m = len(order)
    pos = np.full(graph.shape[0], -1, np.int64)
    pos[order] = np.arange(m)
    # BFS order is by depth, and the parents' positions never decrease along it, so level k + 1 is the
    # run of nodes whose parents lie in level k: below(j) = how many nodes have a parent before position
    # j, and the level boundaries are its iterates from 0.
    below = np.cumsum(np.bincount(pos[pred[order]] + 1, minlength=m + 1)).item
    bounds = [0]
    b = 0
    while b < m:
        b = max(below(b), b + 1)
        bounds.append(b)
    return order, np.repeat(np.arange(len(bounds) - 1, dtype=np.float64), np.diff(bounds))


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
    i, frac = densify_steps(xy, spacing)
    return np.vstack((xy[i] + (xy[i + 1] - xy[i]) * frac[:, None], xy[-1:]))


def densify_steps(xy: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``densify``'s points but the last, as (segment index, fraction along that segment) of a polyline of two
    or more points."""
    seg = np.diff(xy, axis=0)
    n = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / spacing).astype(int), 1)
    i = np.repeat(np.arange(len(seg)), n)
    t = np.arange(len(i)) - np.repeat(np.cumsum(n) - n, n)  # 0..n_k-1 within each segment
    return i, t / n[i]


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
        return self.lattice.fill(self.passable, self._goal_targets(plan_xy))

    def distances(self, plan_xy: np.ndarray, goal_plans: tuple[np.ndarray, ...] = ()) -> list[np.ndarray]:
        """[path distance, goal distance of each of ``goal_plans`` (default: of the plan)] in one go."""
        cells = plan_cells(self.grid, self.resolution, self.origin, plan_xy)
        goals = [self._goal_targets(g) for g in goal_plans] if goal_plans else [cells[-1:]]
        return self.lattice.fill_many(self.passable, [cells, *goals])

    def _goal_targets(self, plan_xy: np.ndarray) -> np.ndarray:
        cell = self.local_goal_cell(plan_xy)
        return np.zeros(0, np.int64) if cell is None else np.array([cell])
