"""How well a SLAM map matches the simulator's world: distance of mapped walls from true walls."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from common.geometry import Pose2D
from common.messages import OccupancyGrid
from deploy.stack.world_maps import world_path
from robot_side.sim.world import WorldParams, load_world


@dataclass(frozen=True)
class MapAccuracy:
    occupied_cells: int
    within_two_cells: float  # fraction of mapped occupied cells within 2 map cells of a true obstacle
    mean_error_m: float
    p95_error_m: float

    def __str__(self) -> str:
        return (f"{self.occupied_cells} occupied cells, {100 * self.within_two_cells:.1f} % within two cells "
                f"of a true wall, mean {self.mean_error_m:.3f} m, p95 {self.p95_error_m:.3f} m")


def map_accuracy(grid: OccupancyGrid, world: str, map_in_world: Pose2D, min_height: float = 0.05) -> MapAccuracy:
    """Compare ``grid`` (frame whose pose in the world is ``map_in_world``) with the true world."""
    w = load_world(world_path(world), WorldParams(resolution=0.02))
    truth = w.occupied(min_height)  # (rows = y, cols = x) at w.resolution from w.origin
    dist = ndimage.distance_transform_edt(~truth) * w.resolution  # m to the nearest true obstacle
    rows, cols = np.nonzero(grid.data >= 65)
    if len(rows) == 0:
        return MapAccuracy(0, 0.0, float("inf"), float("inf"))
    pts = np.column_stack((grid.origin.x + (cols + 0.5) * grid.resolution,
                           grid.origin.y + (rows + 0.5) * grid.resolution))
    xy = map_in_world.apply(pts)
    c = np.floor((xy[:, 0] - w.origin[0]) / w.resolution).astype(int)
    r = np.floor((xy[:, 1] - w.origin[1]) / w.resolution).astype(int)
    inside = (r >= 0) & (c >= 0) & (r < dist.shape[0]) & (c < dist.shape[1])
    d = np.full(len(xy), np.inf)
    d[inside] = dist[r[inside], c[inside]]
    # a cell's centre is up to half a cell from the wall face it stands for
    err = np.maximum(d - grid.resolution / 2, 0.0)
    return MapAccuracy(len(err), float(np.mean(err <= 2 * grid.resolution)), float(np.mean(err[np.isfinite(err)])),
                       float(np.percentile(err, 95)))


FIT_CAP_M = 0.5  # WorldTruth.fit: a mapped wall farther than this from any true one counts as this far
FIT_MIN_CELLS = 50  # ... and fits nothing on fewer occupied cells than this
NO_OFFSET = Pose2D(0.0, 0.0, 0.0)
FIT_HEADINGS_DEG = (-2.0, -1.0, 0.0, 1.0, 2.0)  # a finished map's fit, searched from these turns of the guess


@dataclass(frozen=True)
class WorldTruth:
    """A world's cells at a map's resolution, prepared once to judge many maps of one exploration run:
    the free cells the robot can reach from its start (4-connected free space, as in
    World.to_occupancy_grid), each cell's distance to the nearest true obstacle, and where the map's
    frame lies in the world (SLAM's map frame is the robot's start)."""
    free_xy: np.ndarray  # (n, 2) world x, y of the reachable free cells beyond ``margin_m`` of an obstacle
    dist: np.ndarray  # per world cell: m to the nearest true obstacle, or minus the depth inside one
    origin: tuple[float, float]
    resolution: float
    map_in_world: Pose2D
    margin_m: float

    @staticmethod
    def of(world: str, map_in_world: Pose2D, resolution: float, min_height: float = 0.05,
           margin_m: float = 0.1, edge_walls: bool = False) -> WorldTruth:
        """``margin_m``: cells this near a true obstacle are not judged free or not (a wall's face falls
        anywhere within a map cell); ``edge_walls``: the simulator's (``WorldParams.edge_walls``)."""
        w = load_world(world_path(world), WorldParams(resolution=resolution, edge_walls=edge_walls),
                       start=map_in_world)
        truth = w.to_occupancy_grid(min_height, unknown_unreachable=True).data
        dist = (ndimage.distance_transform_edt(truth != 100) - ndimage.distance_transform_edt(truth == 100)) \
            * w.resolution
        rows, cols = np.nonzero((truth == 0) & (dist > margin_m))
        xy = np.column_stack((w.origin[0] + (cols + 0.5) * w.resolution, w.origin[1] + (rows + 0.5) * w.resolution))
        return WorldTruth(xy, dist, (float(w.origin[0]), float(w.origin[1])), float(w.resolution), map_in_world,
                          margin_m)

    @property
    def free_m2(self) -> float:
        return len(self.free_xy) * self.resolution**2

    def _map_values(self, grid: OccupancyGrid, world_xy: np.ndarray) -> np.ndarray:
        """The map's value at world points (-2 off the map)."""
        xy = self.map_in_world.inverse().apply(world_xy)
        c = np.floor((xy[:, 0] - grid.origin.x) / grid.resolution).astype(int)
        r = np.floor((xy[:, 1] - grid.origin.y) / grid.resolution).astype(int)
        inside = (r >= 0) & (c >= 0) & (r < grid.data.shape[0]) & (c < grid.data.shape[1])
        out = np.full(len(xy), -2, np.int16)
        out[inside] = grid.data[r[inside], c[inside]]
        return out

    def moved(self, correction: Pose2D) -> WorldTruth:
        """The same world judging maps whose frame lies at ``map_in_world`` ∘ ``correction``."""
        return dataclasses.replace(self, map_in_world=self.map_in_world.compose(correction))

    def fit(self, grid: OccupancyGrid, guess: Pose2D = NO_OFFSET,
            headings_deg: tuple[float, ...] = (0.0,)) -> Pose2D:
        """The rigid correction of the map's frame (see ``moved``) that best lays its occupied cells on the
        world's obstacles: least mean distance, each capped at ``FIT_CAP_M``, searched locally from ``guess``
        turned by each of ``headings_deg``. SLAM's map frame is the robot's start only as well as its first
        metres of odometry: a map turned by 1° about it is a right map in a frame 1° off, yet half its walls
        lie more than two cells from the truth 20 m away. Maps are compared after this alignment (as map
        evaluations do); a bent map stays bent. Fewer than ``FIT_MIN_CELLS`` occupied cells: ``guess``."""
        rows, cols = np.nonzero(grid.data >= 65)
        if len(rows) < FIT_MIN_CELLS:
            return guess
        pts = np.column_stack((grid.origin.x + (cols + 0.5) * grid.resolution,
                               grid.origin.y + (rows + 0.5) * grid.resolution))
        capped = np.minimum(np.abs(self.dist), FIT_CAP_M)

        def cost(p: np.ndarray) -> float:
            xy = self.map_in_world.compose(Pose2D(p[0], p[1], np.radians(p[2]))).apply(pts)
            rc = [(xy[:, 1] - self.origin[1]) / self.resolution - 0.5,  # cell values stand at cell centres
                  (xy[:, 0] - self.origin[0]) / self.resolution - 0.5]
            return float(np.mean(ndimage.map_coordinates(capped, rc, order=1, mode="constant", cval=FIT_CAP_M)))

        best: tuple[float, np.ndarray] | None = None
        for dh in headings_deg:
            x0 = np.array([guess.x, guess.y, np.degrees(guess.theta) + dh])
            simplex = np.vstack([x0, x0 + [0.05, 0, 0], x0 + [0, 0.05, 0], x0 + [0, 0, 0.5]])  # m, m, degrees
            r = optimize.minimize(cost, x0, method="Nelder-Mead",
                                  options=dict(initial_simplex=simplex, xatol=2e-3, fatol=1e-6, maxiter=400))
            if best is None or r.fun < best[0]:
                best = (float(r.fun), r.x)
        assert best is not None
        x, y, deg = best[1]
        return Pose2D(float(x), float(y), float(np.radians(deg)))

    def explored(self, grid: OccupancyGrid) -> float:
        """The share of the reachable free area that ``grid`` knows as free."""
        v = self._map_values(grid, self.free_xy)
        return float(np.mean((v >= 0) & (v < 25))) if len(v) else 0.0

    def agreement(self, grid: OccupancyGrid) -> tuple[float, float]:
        """(the share of the map's occupied cells (from 65) within two map cells of a true obstacle, the
        share of its free cells (below 25) on true free space). Free cells within ``margin_m`` of an
        obstacle's face, on either side, are not judged: the face falls anywhere in a cell. Two shares, not
        one over all cells: free cells outnumber walls so far that a map with every wall half a metre off
        would still agree at 97 %."""
        _, occupied, ok_occ, judged_free, ok_free = self._judge(grid)
        if len(occupied) == 0:
            return 0.0, 0.0

        def share(ok: np.ndarray, judged: np.ndarray) -> float:
            n = int(np.count_nonzero(judged))
            return float(np.count_nonzero(ok) / n) if n else 1.0

        return share(ok_occ, occupied), share(ok_free, judged_free)

    def _judge(self, grid: OccupancyGrid) -> tuple[np.ndarray, ...]:
        """``agreement``'s verdict per judged map cell: (the world cell (row, col) it falls on, or -1 off the
        world; occupied; an occupied cell near a true obstacle; a free cell judged; a free cell right)."""
        rows, cols = np.nonzero(((grid.data >= 0) & (grid.data < 25)) | (grid.data >= 65))
        pts = np.column_stack((grid.origin.x + (cols + 0.5) * grid.resolution,
                               grid.origin.y + (rows + 0.5) * grid.resolution))
        xy = self.map_in_world.apply(pts)
        c = np.floor((xy[:, 0] - self.origin[0]) / self.resolution).astype(int)
        r = np.floor((xy[:, 1] - self.origin[1]) / self.resolution).astype(int)
        inside = (r >= 0) & (c >= 0) & (r < self.dist.shape[0]) & (c < self.dist.shape[1])
        d = np.full(len(xy), -np.inf)  # off the world: nothing there agrees
        d[inside] = self.dist[r[inside], c[inside]]
        occupied = grid.data[rows, cols] >= 65
        ok_occ = occupied & (d - grid.resolution / 2 <= 2 * grid.resolution) & np.isfinite(d)
        judged_free = ~occupied & (np.abs(d) > self.margin_m)
        ok_free = judged_free & (d > self.margin_m)
        return np.where(inside[:, None], np.column_stack((r, c)), -1), occupied, ok_occ, judged_free, ok_free

    def picture(self, grid: OccupancyGrid) -> np.ndarray:
        """The map laid on the world as ``agreement`` judges it, an RGB image (rows, cols, 3), north up, one
        pixel per world cell: the true obstacles light blue, the map's walls black where right and red where
        more than two cells from any true obstacle, its free cells on obstacles orange. Where the red lies
        says what broke: a whole wing off, or short walls at an angle in rooms where the robot turned."""
        img = np.full(self.dist.shape + (3,), 255, np.uint8)
        img[self.dist <= 0] = (170, 190, 255)
        at, occupied, ok_occ, judged_free, ok_free = self._judge(grid)
        on = at[:, 0] >= 0
        for cells, colour in ((judged_free & ~ok_free, (255, 150, 0)), (ok_occ, (0, 0, 0)),
                              (occupied & ~ok_occ, (230, 0, 0))):
            rc = at[cells & on]
            img[rc[:, 0], rc[:, 1]] = colour
        return img[::-1]


def explored_share(grid: OccupancyGrid, world: str, map_in_world: Pose2D, min_height: float = 0.05,
                   margin_m: float = 0.1) -> tuple[float, float]:
    """(the share of ``world``'s free area the robot can reach from ``map_in_world`` that ``grid`` knows as
    free, that area in m²)."""
    truth = WorldTruth.of(world, map_in_world, grid.resolution, min_height, margin_m)
    return truth.explored(grid), truth.free_m2
