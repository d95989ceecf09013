"""What move_base's state machine asks of its collaborators (as nav2's GlobalPlanner, Controller and
Behavior interfaces): anything with these methods plugs in, checked by the type checker, not at run time.

- ``GlobalPlanner``: plans toward the current goal on its own schedule (``planner_frequency``) and hands
  results over when polled — ``planner_thread.PlannerThread`` (the node: a thread, ROS's planner thread)
  and ``ImmediatePlanner`` (in process and tests: plans inside ``poll``).
- ``Controller``: follows the plan handed to it (``controller.LocalController`` around a local planner).
- ``Recovery``: one recovery behaviour, ticked until done (``recovery.ClearCostmapRecovery``,
  ``recovery.RotateRecovery``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from common.geometry import Pose2D
from master_side.planning.local.base import Velocity

if TYPE_CHECKING:
    from master_side.move_base.machine_types import ControlResult
    from master_side.move_base.params import MoveBaseParams
    from master_side.move_base.planner_thread import PlanOutcome

class GlobalPlanner(Protocol):
    def start(self, goal: Pose2D) -> None:
        """Plan toward ``goal`` from now on (a new goal replaces the old one)."""

    def stop(self) -> None:
        """No more plans until the next ``start``."""

    def wake(self) -> None:
        """Plan again now (not waiting for the next period)."""

    def poll(self, now: float, pose: Pose2D | None) -> PlanOutcome:
        """The newest result since the last poll (``PlanOutcome.result`` None when there is none)."""

    def close(self) -> None: ...


class Controller(Protocol):
    def set_plan(self, path: np.ndarray) -> None:
        """A new global plan, (N, 3) rows of (x, y, theta) in the global frame."""

    def compute(self, pose: Pose2D, velocity: Velocity) -> ControlResult:
        """The command for this cycle, or why there is none."""

    def goal_reached(self, pose: Pose2D, velocity: Velocity) -> bool: ...


class Recovery(Protocol):
    name: str

    def enabled(self, params: MoveBaseParams) -> bool:
        """Whether move_base's parameters allow this behaviour (e.g. clearing_rotation_allowed)."""

    def start(self, now: float) -> None:
        """Called on the first tick of the behaviour."""

    def step(self, now: float, pose: Pose2D, velocity: Velocity) -> tuple[Velocity, bool]:
        """(command, done) for one tick."""
