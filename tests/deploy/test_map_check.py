"""deploy/stack/map_check.WorldTruth: how much of a world a map knows and how far to trust it, on the room
world's own ground truth as the map (all known, all right), then spoiled in known ways."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from common.geometry import Pose2D
from deploy.stack.map_check import WorldTruth, explored_share
from deploy.stack.world_maps import world_path
from robot_side.sim.world import WorldParams, load_world

START = Pose2D(-2.2, 0.0, 0.0)  # robot_side/worlds/room.yaml's start: SLAM's map frame


@pytest.fixture(scope="module")
def truth_map():
    """The room as a robot would map it from START, in START's frame (yaw 0: a shifted origin)."""
    w = load_world(world_path("room"), WorldParams(resolution=0.05))
    g = w.to_occupancy_grid(0.05, unknown_unreachable=True)
    return dataclasses.replace(g, origin=Pose2D(g.origin.x - START.x, g.origin.y - START.y, 0.0))


def test_the_worlds_own_map_is_fully_explored_and_agrees(truth_map):
    truth, g = WorldTruth.of("room", START, 0.05), truth_map
    assert truth.explored(g) == pytest.approx(1.0)
    assert truth.agreement(g) == pytest.approx((1.0, 1.0))
    share, m2 = explored_share(g, "room", START)
    assert share == pytest.approx(1.0) and m2 == pytest.approx(truth.free_m2) and 10 < m2 < 40


def test_unknown_half_and_a_wall_drawn_off_by_half_a_metre_lower_the_figures(truth_map):
    truth = WorldTruth.of("room", START, 0.05)
    half = truth_map.data.copy()
    half[:, half.shape[1] // 2:] = -1
    got = truth.explored(dataclasses.replace(truth_map, data=half))
    assert 0.3 < got < 0.7
    assert truth.agreement(dataclasses.replace(truth_map, data=half)) == pytest.approx((1.0, 1.0))  # unknown: no error

    shifted = np.roll(truth_map.data, 10, axis=1)  # every wall 0.5 m east of where it is
    walls, free = truth.agreement(dataclasses.replace(truth_map, data=shifted))
    assert walls < 0.8 and free < 1.0, (walls, free)  # the free cells now on walls
    assert truth.explored(dataclasses.replace(truth_map, data=np.full_like(half, -1))) == 0.0
