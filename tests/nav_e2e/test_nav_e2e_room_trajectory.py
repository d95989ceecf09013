"""The trajectory-rollout master config (master_side/config/p3at_known_map_trajectory.yaml) over the bus:
`zenav robot` + `zenav master` as separate processes on a private loopback bus, a goal given in base_link.
Its world goals are driven in one process (test_nav_inproc_world_goals.py); the DWA config's room module
drives them over the bus."""

from __future__ import annotations

import pytest

from testkit.nav_stack import NavStack
from tests.nav_e2e.nav_e2e_checks import check_base_link_goal

SPEED = 2.0  # the master follows the sim clock (use_sim_time), measured stable at 2x on 2 loaded cores


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    s = NavStack(tmp_path_factory.mktemp("room_trajectory"), "room", "trajectory", SPEED)
    yield s
    s.close()


def test_nav_e2e_room_trajectory_base_link_goal_lands_at_the_offset_from_the_robot(stack):
    # at the world's start (-2.2, 0, 0): 1 m ahead of the robot and 0.5 m to its left, turned +90 deg
    check_base_link_goal(stack, (1.0, 0.5, 1.5708))
