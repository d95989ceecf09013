"""Grids and the P3-AT's outline shared by the escape's planning and driving tests."""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, LETHAL
from master_side.move_base.escape_recovery import EscapeRecovery
from master_side.planning.local.scoring_context import footprint_outline

RES = 0.025
ORIGIN = (-2.0, -2.0)
# the P3-AT's outline (p3at/costmap_common_params.yaml)
P3AT = np.array([[0.3302, -0.0508], [0.254, -0.0508], [0.254, -0.254], [-0.254, -0.254], [-0.254, 0.254],
                 [0.254, 0.254], [0.254, 0.0508], [0.3302, 0.0508]])


def grid_with(*boxes: tuple[float, float, float, float]) -> np.ndarray:
    """A 4 m x 4 m grid centred on the robot, LETHAL in each (x0, y0, x1, y1) box (metres)."""
    g = np.full((160, 160), FREE, np.uint8)
    for x0, y0, x1, y1 in boxes:
        c0, r0 = int((x0 - ORIGIN[0]) / RES), int((y0 - ORIGIN[1]) / RES)
        c1, r1 = int(math.ceil((x1 - ORIGIN[0]) / RES)), int(math.ceil((y1 - ORIGIN[1]) / RES))
        g[max(r0, 0):r1, max(c0, 0):c1] = LETHAL
    return g


def min_clearance(grid: np.ndarray, pose: Pose2D) -> float:
    """Least distance from the outline at ``pose`` to a LETHAL cell centre (brute force)."""
    rows, cols = np.nonzero(grid == LETHAL)
    cells = np.column_stack((ORIGIN[0] + (cols + 0.5) * RES, ORIGIN[1] + (rows + 0.5) * RES))
    pts = pose.apply(footprint_outline(P3AT, 0.01))
    return float(np.min(np.hypot(*(pts[:, None, :] - cells[None, :, :]).transpose(2, 0, 1))))


class FakeBase:
    """The robot integrating the escape's commands, and the view the recovery reads."""

    def __init__(self, grid: np.ndarray) -> None:
        self.grid, self.pose = grid, Pose2D()

    def view(self):
        return self.grid, RES, ORIGIN, self.pose

    def run(self, rec: EscapeRecovery, dt: float = 0.1, limit: int = 400, held_after: float = float("inf")) -> int:
        """Ticks until the escape ends; ``held_after``: from this far along its move (m or rad) the robot no
        longer moves, as against a wall no sensor shows."""
        rec.start(0.0)
        moved = 0.0
        for i in range(limit):
            (v, _, w), done = rec.step(i * dt, self.pose, (0.0, 0.0, 0.0))
            if done:
                return i
            if moved < held_after:
                self.pose = self.pose.compose(Pose2D(v * dt, 0.0, w * dt))
                moved += abs(v or w) * dt
        raise AssertionError("the escape never ended")
