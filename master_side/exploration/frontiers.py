"""Frontier search on a costmap, after explore_lite (our code).

The robot's centre can be on the free cells (below INSCRIBED) 4-connected to its own cell (or to the free cell
nearest it, when it stands on a costly one): the reachable cells. From them it sees a little further, into the
band along walls where its centre cannot go: the known cells that are not LETHAL within ``inscribed_radius``
(plus a cell) of a reachable cell, and joined to them without crossing a LETHAL one. A frontier cell is an
unknown cell (NO_INFORMATION) 4-connected to those. (explore_lite asks for a FREE neighbour: in a corridor or
a doorway seen at a slant, that left frontiers of a few cells, under ``min_frontier_size``, and exploration
ended at the first door.) Frontier cells are grouped 8-connected into frontiers; each has its size (cells),
centroid, and the cell nearest the robot (``middle``, at ``min_distance``). The place to send the robot
(``goal``) is where it can stand: the reachable cell nearest the frontier cell nearest the centroid, or
one where it can also turn in place (``circumscribed_radius`` clear of walls) if that is at most
``roomy_detour`` further (a goal facing the frontier by a wall failed: "rotation would collide")
(explore_lite sends the centroid, which lies in unknown space, in a wall, or inside a crate, and move_base
refused such goals). Frontiers smaller than ``min_frontier_size`` metres are dropped. The cost is
explore_lite's, ``potential_scale * min_distance * resolution - gain_scale * size * resolution`` (its
distance in metres, its size in cells: the distance term is scaled by the resolution once more, so with
its launch file's potential_scale 3.0 a metre of frontier is worth 6.7 m of travel on a 0.05 m map),
cheapest first.
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
    goal: tuple[float, float]  # where to send the robot: a reachable cell beside the frontier's middle part


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


def _known_box(known: np.ndarray, pad: int = 2, keep: tuple[int, int] | None = None) -> tuple[slice, slice] | None:
    """The rows and columns holding every ``known`` cell and the cell ``keep`` (row, col), ``pad`` cells
    wider (None: nothing known)."""
    rows, cols = np.nonzero(known.any(axis=1))[0], np.nonzero(known.any(axis=0))[0]
    if len(rows) == 0:
        return None
    lo_r, hi_r, lo_c, hi_c = rows[0], rows[-1], cols[0], cols[-1]
    if keep is not None:
        lo_r, hi_r, lo_c, hi_c = min(lo_r, keep[0]), max(hi_r, keep[0]), min(lo_c, keep[1]), max(hi_c, keep[1])
    h, w = known.shape
    return (slice(max(lo_r - pad, 0), min(hi_r + pad + 1, h)), slice(max(lo_c - pad, 0), min(hi_c + pad + 1, w)))


def grid_from_map(data: np.ndarray, resolution: float, origin: tuple[float, float],
                  inscribed_radius: float, occupied: int = 65, keep: tuple[float, float] | None = None) -> Grid:
    """A SLAM map (OccupancyGrid values: -1 unknown, 0..100) as costs: unknown, LETHAL from ``occupied``,
    INSCRIBED within ``inscribed_radius`` of a LETHAL cell (where the robot's centre cannot go), else FREE.
    Only the part holding known cells (and a margin of unknown ones) is kept: a SLAM map is mostly unknown,
    and the distance transform of a whole 100 m map took a third of a second. ``keep`` (x, y): a point the
    part must hold too, the robot's (it can stand on unknown cells: it backed into the mall's unknown)."""
    data = np.asarray(data)
    at = None if keep is None else Grid(data, resolution, origin).cell(*keep)
    box = _known_box(data >= 0, keep=at)
    if box is not None:
        data = data[box]
        origin = (origin[0] + box[1].start * resolution, origin[1] + box[0].start * resolution)
    lethal = data >= occupied
    cost = np.where(data < 0, NO_INFORMATION, FREE).astype(np.uint8)
    if lethal.any():
        near = ndimage.distance_transform_edt(~lethal) * resolution <= inscribed_radius
        cost[near & (data >= 0)] = INSCRIBED
    cost[lethal] = LETHAL
    return Grid(cost, resolution, origin)


def costmap_forbidden(grid: Grid, costmap: Grid) -> np.ndarray:
    """The cells of ``grid`` (bool, its shape) whose point lies on a ``costmap`` cell at INSCRIBED or above
    (navfn's impassable cells; unknown costmap cells and cells off it are not forbidden).

    A goal beside a frontier chosen on SLAM's map alone could lie on an obstacle move_base's global costmap
    holds and the map does not (yet): move_base refused it ("in an obstacle"), the frontier was blacklisted,
    and in the mall that ended exploration at 2.5 % (explore_lite searches the costmap itself). Only the goal
    avoids these cells (``search``'s ``no_goal``): laid over the map for the whole search, the costmap's
    obstacles, left a little off by SLAM's corrections, walled the robot into a pocket, and a mall run saw one
    frontier where the map had 48."""
    def along(n: int, axis: int) -> tuple[np.ndarray, np.ndarray]:
        """The costmap's index of each of the grid's ``n`` cell centres along ``axis`` (0: x, 1: y), and
        which of them fall on it (both grids are axis-aligned: rows and columns map separately)."""
        centres = grid.origin[axis] + (np.arange(n) + 0.5) * grid.resolution
        i = np.floor((centres - costmap.origin[axis]) / costmap.resolution).astype(np.int64)
        size = costmap.data.shape[1 - axis]
        return np.clip(i, 0, size - 1), (i >= 0) & (i < size)

    (cr, rows_on), (cc, cols_on) = along(grid.data.shape[0], 1), along(grid.data.shape[1], 0)
    cost = costmap.data[np.ix_(cr, cc)]
    return rows_on[:, None] & cols_on[None, :] & (cost >= INSCRIBED) & (cost != NO_INFORMATION)


def nearest_lethal_m(grid: Grid, x: float, y: float, within: float) -> float:
    """Distance from (x, y) to the nearest edge of a LETHAL cell of ``grid`` no farther than ``within`` (inf:
    none there). A turn in place sweeps the footprint's circumscribed circle: it is free when this is larger."""
    n = int(np.ceil(within / grid.resolution)) + 1
    c = int(np.floor((x - grid.origin[0]) / grid.resolution))
    r = int(np.floor((y - grid.origin[1]) / grid.resolution))
    h, w = grid.data.shape
    r0, r1, c0, c1 = max(r - n, 0), min(r + n + 1, h), max(c - n, 0), min(c + n + 1, w)
    if r0 >= r1 or c0 >= c1:
        return float("inf")
    rows, cols = np.nonzero(grid.data[r0:r1, c0:c1] == LETHAL)
    if len(rows) == 0:
        return float("inf")
    d = np.hypot(*(grid.centres(rows + r0, cols + c0) - (x, y)).T) - 0.5 * grid.resolution
    d = d[d <= within]
    return max(float(d.min()), 0.0) if len(d) else float("inf")


def reachable(grid: Grid, robot: tuple[float, float], seed_radius: float = 0.0) -> np.ndarray:
    """Free cells (cost below INSCRIBED) 4-connected to a free cell within ``seed_radius`` of the robot (on
    its side of any wall), or else to the free cell nearest it.

    The radius is the robot's own: SLAM's map can leave the cell the robot stands on in a pocket of a few free
    cells, cut off by an inflated speck from the free space a cell beside it. Searched from the pocket alone,
    the mall's exploration saw one frontier, blacklisted it and ended at 19 % known, with the rest 0.1 m away."""
    free = grid.data < INSCRIBED
    at = grid.cell(*robot)
    if at is None:
        raise ValueError(f"the robot at ({robot[0]:.2f}, {robot[1]:.2f}) is outside the costmap")
    labels, _ = ndimage.label(free, structure=_FOUR)
    seeds = np.zeros(0, labels.dtype)
    k = int(seed_radius / grid.resolution + 1e-9)
    if k > 0:
        (h, w), r0, c0 = free.shape, max(at[0] - k, 0), max(at[1] - k, 0)
        win = (slice(r0, min(at[0] + k + 1, h)), slice(c0, min(at[1] + k + 1, w)))
        rr, cc = np.mgrid[win]
        disc = (rr - at[0]) ** 2 + (cc - at[1]) ** 2 <= k * k
        # not through a wall: the known, non-lethal cells joined to the robot's inside the window
        parts, _ = ndimage.label((grid.data[win] != LETHAL) & (grid.data[win] != NO_INFORMATION), structure=_FOUR)
        mine = parts[at[0] - r0, at[1] - c0]
        if mine > 0:
            seeds = np.unique(labels[win][disc & (parts == mine)])
            seeds = seeds[seeds > 0]
    if len(seeds) == 0:
        if not free[at]:
            rr, cc = np.nonzero(free)
            if len(rr) == 0:
                return np.zeros_like(free)
            i = int(np.argmin((rr - at[0]) ** 2 + (cc - at[1]) ** 2))
            at = (int(rr[i]), int(cc[i]))
        return labels == labels[at]
    return np.isin(labels, seeds)


POCKET_SHARE = 0.1  # the robot's free region under this share of the known free area: a pocket (``search``)


def across_band(grid: Grid, reach: np.ndarray) -> np.ndarray:
    """The free cells joined to ``reach`` through known cells that are not LETHAL: the band along walls where
    the robot's centre cannot stand is crossed, as navfn crosses it on a costmap that holds only what the
    sensors mark. The mall: the robot had driven into 6.9 m^2 of SLAM's map cut off from the other 689 m^2 by
    such a band (SLAM's walls a little off the ones it passed), saw one frontier from there and ended at 71 %."""
    parts, _ = ndimage.label((grid.data != LETHAL) & (grid.data != NO_INFORMATION), structure=_FOUR)
    mine = np.unique(parts[reach])
    return (grid.data < INSCRIBED) & np.isin(parts, mine[mine > 0])


def search(grid: Grid, robot: tuple[float, float], potential_scale: float = 3.0, gain_scale: float = 1.0,
           min_frontier_size: float = 0.5, inscribed_radius: float = 0.254,
           circumscribed_radius: float = 0.0, roomy_detour: float = 1.0,
           no_goal: np.ndarray | None = None) -> list[Frontier]:
    """The frontiers seen from where the robot can reach from ``robot`` (x, y in the grid's frame),
    cheapest first; ``no_goal`` (bool, the grid's shape): cells no goal may lie on (costmap_forbidden), as
    long as some reachable cell is left."""
    if grid.cell(*robot) is None:
        raise ValueError(f"the robot at ({robot[0]:.2f}, {robot[1]:.2f}) is outside the costmap")
    box = _known_box(grid.data != NO_INFORMATION, keep=grid.cell(*robot))  # a SLAM map is mostly unknown
    if box is None:
        return []
    sub = Grid(grid.data[box], grid.resolution, (grid.origin[0] + box[1].start * grid.resolution,
                                                  grid.origin[1] + box[0].start * grid.resolution))
    if no_goal is not None and no_goal.shape != grid.data.shape:
        raise ValueError(f"no_goal {no_goal.shape} is not the grid's shape {grid.data.shape}")
    if sub.cell(*robot) is None:
        return []
    reach = reachable(sub, robot, inscribed_radius)
    if not reach.any():
        return []
    if reach.sum() < POCKET_SHARE * np.count_nonzero(sub.data < INSCRIBED):  # a pocket: look across the band
        reach = across_band(sub, reach)
    dist = ndimage.distance_transform_edt(~reach)  # to the nearest reachable cell, for every cell
    stand = reach if no_goal is None else reach & ~no_goal[box]  # where goals may go
    if not stand.any():
        stand = reach
    # distance to, and index of, the nearest cell a goal may take, for every cell
    goal_dist, (near_r, near_c) = ndimage.distance_transform_edt(~stand, return_indices=True)
    open_known = (sub.data != NO_INFORMATION) & (sub.data != LETHAL)
    parts, _ = ndimage.label(open_known, structure=_FOUR)  # not through a wall: the reachable cells' part
    mine = np.unique(parts[reach])
    seen = np.isin(parts, mine[mine > 0]) & (dist * sub.resolution <= inscribed_radius + sub.resolution)
    frontier = (sub.data == NO_INFORMATION) & ndimage.binary_dilation(seen, structure=_FOUR)
    labels, n = ndimage.label(frontier, structure=_EIGHT)
    if n == 0:
        return []
    # goals where the robot can also turn in place (``circumscribed_radius`` clear of LETHAL cells), if one is
    # at most ``roomy_detour`` further from the frontier than the nearest reachable cell
    roomy_dist, roomy_r, roomy_c = None, near_r, near_c
    if circumscribed_radius > 0:
        roomy = stand & (ndimage.distance_transform_edt(sub.data != LETHAL) * sub.resolution
                         >= circumscribed_radius + sub.resolution / 2)
        if roomy.any():
            roomy_dist, (roomy_r, roomy_c) = ndimage.distance_transform_edt(~roomy, return_indices=True)
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    xy = sub.centres(rows, cols)
    d = np.hypot(xy[:, 0] - robot[0], xy[:, 1] - robot[1])
    out = []
    order = np.argsort(ids, kind="stable")
    bounds = np.searchsorted(ids[order], np.arange(1, n + 2))
    for k in range(n):
        idx = order[bounds[k]:bounds[k + 1]]
        size_m = len(idx) * sub.resolution
        if size_m < min_frontier_size:
            continue
        near = idx[int(np.argmin(d[idx]))]
        cost = potential_scale * float(d[near]) * sub.resolution - gain_scale * size_m  # explore_lite's
        cx, cy = xy[idx].mean(axis=0)
        mid = idx[int(np.argmin(np.hypot(xy[idx, 0] - cx, xy[idx, 1] - cy)))]
        r, c = rows[mid], cols[mid]
        use_roomy = roomy_dist is not None and (roomy_dist[r, c] - goal_dist[r, c]) * sub.resolution <= roomy_detour
        gr, gc = (roomy_r[r, c], roomy_c[r, c]) if use_roomy else (near_r[r, c], near_c[r, c])
        gx, gy = sub.centres(np.array([gr]), np.array([gc]))[0]
        out.append(Frontier(len(idx), size_m, (float(cx), float(cy)), (float(xy[near, 0]), float(xy[near, 1])),
                            float(d[near]), cost, xy[idx], (float(gx), float(gy))))
    out.sort(key=lambda f: f.cost)
    return out
