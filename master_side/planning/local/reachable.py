"""The plan as far as the robot can follow it on the local costmap (zenav's ``cut_off_plan_min_reach``).

ROS's local planners aim at the last pose of the plan inside the local costmap. When the local costmap
closes the way there (a wall the global costmap does not have yet, or one its odometry smeared: on
physics the skid-steered P3-AT's odometry loses part of every turn, and the marks behind the robot drift
across a door), the goal-distance flood fill never reaches the robot and every trajectory is rejected.
The robot stands still for ``controller_patience`` before any recovery runs, and it does not turn its
sensor toward the stale marks that would clear them.

Here, in that case, the plan ends at its farthest pose the robot can reach (a pose on a cell the flood
fill from the robot's cell enters), when that lies at least ``min_reach`` along the plan from the robot.
The robot drives there, its sensors see the place again, and the costmap opens or confirms the block.
Nearer than ``min_reach`` the plan is left whole, so a real block still ends in ROS's way: no valid
command, patience, recoveries.
"""

from __future__ import annotations

import numpy as np

from master_side.planning.local.grid_distance import densify_steps
from master_side.planning.local.scoring_context import ScoringContext


def reachable_plan(ctx: ScoringContext, min_reach: float) -> np.ndarray | None:
    """``ctx.plan`` cut after its farthest point the robot can reach (the plan taken a cell at a time), when its
    local goal is cut off from the robot on the local costmap and that point lies at least ``min_reach`` m
    along the plan; else None. A point is reachable when its cell or one beside it is (ROS's flood fills start
    from a goal cell even in the inscribed band)."""
    r, c, inside = ctx.cells(ctx.pose[None, :2])
    if len(ctx.plan) < 2 or not inside[0] or np.isfinite(ctx.goal_distance()[r[0], c[0]]):
        return None  # not cut off (the goal distance's fill is the one GoalDistance uses: no extra work)
    mg = ctx.map_grid()
    # from the robot's cell (expanded even when it is in the inscribed band, as ROS expands its targets)
    reach = np.pad(np.isfinite(mg.lattice.fill(mg.passable, np.array([r[0] * ctx.grid.shape[1] + c[0]]))), 1)
    goal = mg.local_goal_cell(ctx.plan[:, :2])  # ROS's local goal: the last plan cell on the map and known
    if goal is not None:
        gr, gc = divmod(goal, ctx.grid.shape[1])
        if reach[gr:gr + 3, gc:gc + 3].any():  # reachable after all: only the robot's own cell is blocked
            return None
    plan, along = _dense(ctx.plan, ctx.resolution)
    pr, pc, pin = ctx.cells(plan[:, :2])
    pr, pc = pr + 1, pc + 1
    ok = pin & (reach[pr, pc] | reach[pr - 1, pc] | reach[pr + 1, pc] | reach[pr, pc - 1] | reach[pr, pc + 1])
    if not ok.any():
        return None
    k = int(np.flatnonzero(ok)[-1])
    to_start = float(np.hypot(*(plan[0, :2] - ctx.pose[:2])))
    return plan[:k + 1] if to_start + along[k] >= min_reach else None


def _dense(plan: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``densify``'s points of the plan, each with the heading of the pose its segment starts from, and each
    point's distance along the plan."""
    i, frac = densify_steps(plan[:, :2], spacing)
    seg = plan[i + 1, :2] - plan[i, :2]
    length = np.hypot(*np.diff(plan[:, :2], axis=0).T)
    pts = np.vstack((np.column_stack((plan[i, :2] + seg * frac[:, None], plan[i, 2])), plan[-1:]))
    along = np.concatenate(((np.cumsum(length) - length)[i] + length[i] * frac, [length.sum()]))
    return pts, along
