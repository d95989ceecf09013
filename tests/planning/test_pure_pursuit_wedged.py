"""RegulatedPurePursuit boxed in: turning toward the plan would collide and so would backing up. It stops
and its reason says both (the backing-up part was lost before: a MuJoCo BARN run aborted with a reason
that named the turn alone)."""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D
from master_side.planning.grid import LETHAL
from master_side.planning.local.pure_pursuit import PurePursuitParams, RegulatedPurePursuit

RES = 0.05
BARE = np.array([[-0.25, -0.2], [-0.25, 0.2], [0.25, 0.2], [0.25, -0.2]])


def _boxed(behind: bool):
    """The robot at (2, 2) facing +x between walls 0.3 m ahead (and behind): a half-turn sweeps its corners
    (0.32 m from the centre) through them. The plan leaves along +y."""
    grid = np.zeros((80, 80), np.uint8)
    grid[:, int(2.3 / RES)] = LETHAL
    if behind:
        grid[:, int(1.68 / RES)] = LETHAL
    planner = RegulatedPurePursuit(PurePursuitParams())
    ys = np.linspace(2.0, 3.8, 40)
    planner.set_plan(np.column_stack((np.full_like(ys, 2.0), ys, np.full_like(ys, np.pi / 2))))
    return planner.compute_velocity(Pose2D(2.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), BARE)


def test_boxed_in_it_stops_saying_that_turning_and_backing_up_would_both_collide():
    r = _boxed(behind=True)
    assert not r.ok and r.cmd == (0.0, 0.0, 0.0), r
    assert "turning in place would collide too, and so would backing up" in r.reason, r.reason


def test_with_room_behind_it_backs_up():
    r = _boxed(behind=False)
    assert r.ok and r.cmd[0] < 0.0 and "backing up" in r.reason, r
