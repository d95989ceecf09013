"""navfn global planner: navigation-function potential + gradient-descent path over a costmap grid.

Behaviour follows ROS ``navfn``/``NavfnROS`` (and ``global_planner``'s parameter names):

* cell cost ``neutral_cost + cost_factor * c`` (clipped to 253) for costmap values ``c < lethal_cost``;
  ``c >= lethal_cost`` (default 253: INSCRIBED and LETHAL) is impassable; NO_INFORMATION (255) costs
  253 with ``allow_unknown`` and is impassable without it.
* like NavfnROS (which swaps start and goal), the potential spreads from the **start**; the path is
  read by gradient descent from the goal and reversed, so the goal-tolerance search can pick the
  reachable cell (finite potential) nearest the goal within ``tolerance``.
* the start cell is cleared like NavfnROS ``clearRobotCell`` unless it is LETHAL (StartOccupied).
* unlike navfn the outermost map cells are usable (the solver pads the grid instead).
* the wavefront stops, like navfn's ``calcNavFnDijkstra(atStart=true)``, soon after it reaches the goal:
  once no pending cell could still lower the goal's potential (by more than the margin), counting
  each pending value plus the least rise over its grid distance to the goal, so fronts elsewhere on the
  map need not catch up first. Same potential at the goal and the same path as the global rule.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.geometry import Pose2D
from master_side.planning.errors import GoalOccupied, GoalOutsideMap, NoPath, StartOccupied, StartOutsideMap
from master_side.planning.gradient_path import descend
from master_side.planning.grid import (
    INSCRIBED,
    LETHAL,
    NO_INFORMATION,
    check_grid,
    grid_to_world,
    in_grid,
    world_to_cell,
)
from master_side.planning.potential import INV_SQRT2, pad_costs, propagate

OBSTACLE_COST = 253.0  # navfn COST_OBS - 1: the highest passable cell cost


@dataclass(frozen=True)
class NavfnParams:
    allow_unknown: bool = param(True, doc="plan through NO_INFORMATION cells (at cost 253)")
    planner_window_x: float = param(0.0, lo=0.0, unit="m", doc="if > 0, plan only inside a window this wide")
    planner_window_y: float = param(0.0, lo=0.0, unit="m", doc="if > 0, plan only inside a window this high")
    default_tolerance: float = param(0.0, lo=0.0, unit="m", doc="goal tolerance when none is given")
    visualize_potential: bool = param(False, doc="ask the node to publish the potential (last_potential)")
    use_dijkstra: bool = param(True, doc="Dijkstra-order wavefront; false = A* (Euclidean heuristic)")
    use_quadratic: bool = param(True, doc="planar-wave quadratic update; false = 4-connected Dijkstra step")
    use_grid_path: bool = param(False, doc="follow the lowest 8-neighbour instead of the gradient")
    old_navfn_behavior: bool = param(False, doc="keep navfn's cell-centre end points (no exact start/goal)")
    neutral_cost: int = param(50, lo=1, hi=252, doc="cost of a FREE cell")
    cost_factor: float = param(0.8, lo=0.0, hi=100.0, doc="multiplier of the costmap cost")
    lethal_cost: int = param(253, lo=1, hi=255, doc="costmap values >= this are impassable")

    def cell_costs(self, grid: np.ndarray) -> np.ndarray:
        """navfn cost array (float, inf = impassable) for a uint8 costmap grid."""
        return self.cost_table().take(grid)

    def cost_table(self) -> np.ndarray:
        """(256,) navfn cost of each uint8 costmap value (a lookup is cheaper than arithmetic per cell)."""
        c = np.minimum(self.neutral_cost + self.cost_factor * np.arange(256.0), OBSTACLE_COST)
        c[self.lethal_cost :] = np.inf
        c[NO_INFORMATION] = OBSTACLE_COST if self.allow_unknown else np.inf
        return c


# the costmap values that close a way, by name (what navfn's "no path" reports)
_CLOSED = ((LETHAL, "lethal"), (INSCRIBED, "inscribed"), (NO_INFORMATION, "unknown"))


def enclosure(grid: np.ndarray, reached: np.ndarray, start: tuple[int, int], resolution: float,
              origin_xy: tuple[float, float], lethal_cost: int) -> str:
    """Why the wave stopped: the area it reached from the start, and what closes it (the unreached cells
    bordering it, by costmap value: an obstacle, within the robot's inscribed radius of one, unknown, or
    merely costly), with the border cell nearest the start."""
    from scipy.ndimage import binary_dilation

    border = binary_dilation(reached, structure=np.ones((3, 3), bool)) & ~reached
    v = grid[border].astype(np.int64)
    kinds = (*((name, v == k) for k, name in _CLOSED),
             (f"cost >= {lethal_cost}", (v >= lethal_cost) & (v < INSCRIBED)))
    counts = ", ".join(f"{int(m.sum())} {name}" for name, m in kinds if m.any()) \
        or "none impassable (the search stopped)"
    msg = f"the start's passable region is {reached.sum() * resolution ** 2:.2f} m², closed by {counts}"
    rows, cols = np.nonzero(border)
    if rows.size:
        k = int(np.argmin(np.hypot(rows - start[0], cols - start[1])))
        x, y = grid_to_world(np.array([[cols[k], rows[k]]], float), resolution, origin_xy)[0]
        c = int(grid[rows[k], cols[k]])
        name = dict(_CLOSED).get(c, f"cost {c}")
        msg += f"; the nearest, {name}, at ({x:.2f}, {y:.2f})"
    return msg


def crossing(grid: np.ndarray, passable: np.ndarray, start: tuple[int, int], goal: tuple[int, int],
             resolution: float, origin_xy: tuple[float, float]) -> str:
    """Where the way is closed: the path from start to goal that crosses the fewest impassable cells (each
    costs a thousand free ones, an obstacle's a hundred thousand: inflation or unknown is what may have
    closed a corridor), and the first stretch of them along it, by kind."""
    if not in_grid(grid.shape, *goal):
        return ""
    h, w = grid.shape
    wp = w + 2
    weight = np.where(passable, 1.0, np.where(grid == LETHAL, 1e5, 1e3))
    pot, _ = propagate(pad_costs(weight), wp, (start[0] + 1) * wp + start[1] + 1, (goal[0] + 1) * wp + goal[1] + 1,
                       quadratic=False, max_cycles=4 * h * w)
    cells = descend(pot.reshape(h + 2, wp), (goal[0] + 1, goal[1] + 1), done_below=0.5, grid_only=True,
                    max_steps=8 * (h + w) + 100)
    if cells is None:
        return ""
    uniq, at = np.unique(np.rint(cells).astype(np.int64) - 1, axis=0, return_index=True)
    cr = uniq[np.argsort(at)][::-1]  # (col, row) from the start to the goal, each cell once
    shut = ~passable[cr[:, 1], cr[:, 0]]
    if not shut.any():
        return ""
    first = int(np.argmax(shut))
    end = first + int(np.argmin(shut[first:])) if not shut[first:].all() else len(shut)
    run = cr[first:end]
    v = grid[run[:, 1], run[:, 0]]
    counts = [f"{int((v == k).sum())} {name}" for k, name in _CLOSED if (v == k).any()]
    other = int((~np.isin(v, [k for k, _ in _CLOSED])).sum())
    kinds = ", ".join(counts + ([f"{other} costly"] if other else []))
    x0, y0 = grid_to_world(run[:1].astype(float), resolution, origin_xy)[0]
    x1, y1 = grid_to_world(run[-1:].astype(float), resolution, origin_xy)[0]
    where = f"at ({x0:.2f}, {y0:.2f})" if len(run) == 1 else f"from ({x0:.2f}, {y0:.2f}) to ({x1:.2f}, {y1:.2f})"
    return f"; the cheapest way through first crosses {len(run)} impassable cell(s) ({kinds}) {where}" \
        + (f", {int(shut.sum())} in all" if int(shut.sum()) > len(run) else "")


class NavFn:
    """``make_plan(grid, resolution, origin_xy, start, goal) -> (N, 3)`` poses (x, y, theta)."""

    def __init__(self, params: NavfnParams | None = None):
        self.params = params or NavfnParams()
        self.last_potential: np.ndarray | None = None  # (H, W), inf = unreached (for visualisation)
        self.last_goal_used: Pose2D | None = None
        self.last_cycles = 0

    def make_plan(
        self,
        grid: np.ndarray,
        resolution: float,
        origin_xy: tuple[float, float],
        start: Pose2D,
        goal: Pose2D,
        tolerance: float | None = None,
        timeout: float | None = None,
    ) -> np.ndarray:
        """Plan from ``start`` to ``goal`` (world frame of the grid).

        Raises StartOccupied / StartOutsideMap, GoalOccupied / GoalOutsideMap, NoPath, PlannerTimeout.
        """
        p = self.params
        g = check_grid(grid, resolution)
        tol = p.default_tolerance if tolerance is None else tolerance
        deadline = None if timeout is None else time.monotonic() + timeout
        h, w = g.shape
        sr, sc = world_to_cell(start.x, start.y, resolution, origin_xy)
        gr, gc = world_to_cell(goal.x, goal.y, resolution, origin_xy)
        if not in_grid(g.shape, sr, sc):
            raise StartOutsideMap(f"start ({start.x:.2f}, {start.y:.2f}) is off the costmap")
        if g[sr, sc] == LETHAL:
            raise StartOccupied(f"start ({start.x:.2f}, {start.y:.2f}) is in a lethal cell")
        cost = p.cell_costs(g)
        cost[sr, sc] = p.neutral_cost  # clearRobotCell
        self._apply_window(cost, sr, sc, resolution)
        candidates = self._goal_candidates(cost, gr, gc, tol, resolution, goal)
        wp = w + 2
        src = (sr + 1) * wp + sc + 1
        goal_ok = in_grid(g.shape, gr, gc) and np.isfinite(cost[gr, gc])
        stop = (gr + 1) * wp + gc + 1 if goal_ok else -1
        heur = None
        if not p.use_dijkstra and goal_ok:
            rr, cc = np.mgrid[-1 : h + 1, -1 : w + 1]
            heur = (p.neutral_cost * np.hypot(rr - gr, cc - gc)).ravel()
        pot, self.last_cycles = propagate(
            pad_costs(cost),
            wp,
            src,
            stop,
            quadratic=p.use_quadratic,
            heuristic=heur,
            band=2.0 * p.neutral_cost,
            margin=3.0 * OBSTACLE_COST,
            rise=INV_SQRT2 * p.neutral_cost,  # every passable cell costs >= neutral_cost
            max_cycles=max(h * w // 4, 4 * (h + w)),
            deadline=deadline,
        )
        pot2d = pot.reshape(h + 2, w + 2)
        self.last_potential = pot2d[1:-1, 1:-1]
        cand_pot = self.last_potential[candidates[:, 0], candidates[:, 1]]
        reach = np.flatnonzero(np.isfinite(cand_pot))
        if reach.size == 0:
            raise NoPath(
                f"no path from ({start.x:.2f}, {start.y:.2f}) to ({goal.x:.2f}, {goal.y:.2f})"
                + (f" within tolerance {tol:.2f} m" if tol > 0 else "")
                + "; " + enclosure(g, np.isfinite(self.last_potential), (sr, sc), resolution, origin_xy, p.lethal_cost)
                + crossing(g, np.isfinite(cost), (sr, sc), (gr, gc), resolution, origin_xy)
            )
        er, ec = candidates[reach[0]]  # candidates are sorted by distance to the goal
        cells = descend(
            pot2d,
            (er + 1, ec + 1),
            done_below=float(p.neutral_cost) * 0.999,
            grid_only=p.use_grid_path,
            max_steps=8 * (h + w) + 100,
        )
        if cells is None:
            raise NoPath("gradient descent on the potential got stuck")
        xy = grid_to_world(cells[::-1] - 1.0, resolution, origin_xy)
        exact_goal = (er, ec) == (gr, gc)
        if not p.old_navfn_behavior:  # exact end points; drop the cell-centre points within a cell of them
            end = np.array([goal.x, goal.y]) if exact_goal else xy[-1]
            mid = xy[1:-1]
            far = (np.hypot(*(mid - [start.x, start.y]).T) > resolution) & (
                np.hypot(*(mid - end).T) > resolution
            )
            xy = np.vstack(([start.x, start.y], mid[far], end))
        self.last_goal_used = Pose2D(float(xy[-1, 0]), float(xy[-1, 1]), goal.theta)
        return _with_headings(xy, goal.theta)

    def _apply_window(self, cost: np.ndarray, sr: int, sc: int, resolution: float) -> None:
        """planner_window_x/y: everything outside a window centred on the start is impassable."""
        p = self.params
        for size, axis, centre in ((p.planner_window_x, 1, sc), (p.planner_window_y, 0, sr)):
            if size > 0:
                half = int(math.ceil(size / resolution / 2))
                idx = np.arange(cost.shape[axis])
                outside = np.abs(idx - centre) > half
                if axis == 1:
                    cost[:, outside] = np.inf
                else:
                    cost[outside, :] = np.inf

    @staticmethod
    def _goal_candidates(
        cost: np.ndarray, gr: int, gc: int, tol: float, resolution: float, goal: Pose2D
    ) -> np.ndarray:
        """Passable cells within ``tol`` of the goal cell, nearest first, as (K, 2) rows/cols."""
        h, w = cost.shape
        rad = int(math.floor(tol / resolution + 1e-9))
        if not (-rad <= gr < h + rad and -rad <= gc < w + rad):
            raise GoalOutsideMap(f"goal ({goal.x:.2f}, {goal.y:.2f}) is off the costmap")
        rr, cc = np.mgrid[
            max(gr - rad, 0) : min(gr + rad, h - 1) + 1, max(gc - rad, 0) : min(gc + rad, w - 1) + 1
        ]
        d2 = (rr - gr) ** 2 + (cc - gc) ** 2
        ok = (d2 <= rad * rad) & np.isfinite(cost[rr, cc])
        if not ok.any():
            where = "is off the costmap" if not in_grid(cost.shape, gr, gc) else "is in an obstacle"
            raise (GoalOutsideMap if "off" in where else GoalOccupied)(
                f"goal ({goal.x:.2f}, {goal.y:.2f}) {where}"
                + (f" and no free cell lies within {tol:.2f} m" if tol > 0 else "")
            )
        order = np.argsort(d2[ok], kind="stable")
        return np.column_stack((rr[ok], cc[ok]))[order]


def _with_headings(xy: np.ndarray, final_theta: float) -> np.ndarray:
    """(N, 2) -> (N, 3): heading along the path, the last pose takes ``final_theta``."""
    out = np.zeros((len(xy), 3))
    out[:, :2] = xy
    if len(xy) > 1:
        d = np.diff(xy, axis=0)
        out[:-1, 2] = np.arctan2(d[:, 1], d[:, 0])
    out[-1, 2] = final_theta
    return out


def path_length(path: np.ndarray) -> float:
    """Sum of segment lengths of an (N, >=2) path."""
    return float(np.hypot(*np.diff(path[:, :2], axis=0).T).sum()) if len(path) > 1 else 0.0
