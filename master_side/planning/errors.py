"""Typed planner failures (nav2_core planner_exceptions style); move_base reports ``str(e)``."""

from __future__ import annotations


class PlannerError(RuntimeError):
    """Base class of every global-planner failure."""


class StartOccupied(PlannerError):
    """The start cell is lethal (or otherwise impassable)."""


class StartOutsideMap(StartOccupied):
    """The start is not on the costmap."""


class GoalOccupied(PlannerError):
    """The goal cell and every cell within the goal tolerance are impassable."""


class GoalOutsideMap(GoalOccupied):
    """The goal is not on the costmap."""


class NoPath(PlannerError):
    """Start and goal are not connected through passable cells."""


class PlannerTimeout(PlannerError):
    """Planning took longer than the allowed time."""
