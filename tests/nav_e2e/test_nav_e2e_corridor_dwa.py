"""Issue 6 acceptance on the corridor world with the dwa master config:
`zenav robot` + `zenav master` as separate
processes on a private loopback bus (for the corridor: a copy of the master YAML whose map is exported from
the world with deploy.world_maps.export_world_map)."""

from __future__ import annotations

import pytest

from testkit.nav_stack import NavStack
from tests.nav_e2e.nav_e2e_checks import check_world_goals

SPEED = 2.0  # the master follows the sim clock (use_sim_time), measured stable at 2x on 2 loaded cores


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    s = NavStack(tmp_path_factory.mktemp("corridor_dwa"), "corridor", "dwa", SPEED)
    yield s
    s.close()


def test_nav_e2e_corridor_dwa_reaches_the_world_goals_without_collision(stack):
    check_world_goals(stack)
