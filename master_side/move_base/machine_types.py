"""The values move_base's state machine (``state_machine.MoveBaseMachine``) works in: its states, what
started a recovery, a controller's answer and the machine's decision after each tick."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from common.geometry import Pose2D

__all__ = ["State", "Trigger", "ControlResult", "Decision", "Goal"]


class State(enum.Enum):
    IDLE = "IDLE"
    PLANNING = "PLANNING"
    CONTROLLING = "CONTROLLING"
    CLEARING = "CLEARING"


NO_PLAN = "no plan for"  # how the reason of a goal aborted because no plan was found begins, after "aborted: "


class Trigger(enum.Enum):
    """What started the current recovery sequence (move_base's recovery_trigger_)."""
    PLANNING = "planning"
    CONTROLLING = "controlling"
    OSCILLATION = "oscillation"
    STALL = "stall"


@dataclass(frozen=True)
class ControlResult:
    cmd: tuple[float, float, float] = (0.0, 0.0, 0.0)  # vx, vy, wz
    ok: bool = False
    reason: str = ""  # why no command (e.g. "no valid trajectory: obstacle rejected 400/400")
    trajectory: np.ndarray | None = None


@dataclass(frozen=True)
class Decision:
    """What the node should do after one tick."""

    cmd: tuple[float, float, float]
    state: State
    status: int  # GoalStatus code of the current goal (or of the last one when IDLE)
    reason: str
    new_plan: np.ndarray | None = None  # set when a new plan reached the controller this tick
    event: str = ""  # state-change text for the log ("" if none)


@dataclass
class Goal:
    """The goal being pursued: its id, its pose, the pose planned to (a goal in an obstacle is moved), its plan."""

    goal_id: str
    pose: Pose2D
    used: Pose2D | None = None
    path: np.ndarray | None = None
