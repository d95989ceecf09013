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


def test_a_map_in_a_frame_turned_and_shifted_from_the_start_is_laid_back_where_it_fits(truth_map):
    """SLAM's frame off the start by 3° and 0.14 m (its first metres of odometry): a right map judged at the
    start has walls off; fitted, the frame is found again (to the room's few metres: within 0.05 m and 1°)
    and the map agrees."""
    off = Pose2D(0.1, -0.1, np.radians(3.0))
    truth = WorldTruth.of("room", START.compose(off), 0.05)  # the world seen from the frame that is off
    raw_walls, _ = truth.agreement(truth_map)
    assert raw_walls < 0.9
    found = truth.fit(truth_map, headings_deg=(-2.0, 0.0, 2.0))
    back = off.compose(found)  # the correction undoes the offset
    assert abs(back.x) < 0.05 and abs(back.y) < 0.05 and abs(np.degrees(back.theta)) < 1.0, (found, back)
    assert truth.moved(found).agreement(truth_map) == pytest.approx((1.0, 1.0))
    assert truth.moved(found).explored(truth_map) == pytest.approx(1.0, abs=0.01)


def test_the_fit_does_not_straighten_a_bent_map(truth_map):
    """Half the room's walls drawn 0.5 m off: no frame lays both halves on the world."""
    truth = WorldTruth.of("room", START, 0.05)
    bent = truth_map.data.copy()
    half = bent.shape[1] // 2
    bent[:, half:] = np.roll(bent[:, half:], 10, axis=0)
    g = dataclasses.replace(truth_map, data=bent)
    walls, _ = truth.moved(truth.fit(g, headings_deg=(-2.0, 0.0, 2.0))).agreement(g)
    assert walls < 0.9, walls
    empty = dataclasses.replace(truth_map, data=np.full_like(bent, -1))
    assert truth.fit(empty, Pose2D(0.1, 0.0, 0.0)) == Pose2D(0.1, 0.0, 0.0)  # nothing to fit: the guess


def test_the_picture_shows_wrong_walls_red_and_reads_back_from_its_png(truth_map, tmp_path):
    """A right map: its walls black on the true walls, no red. Every wall 0.5 m off: red pixels, as many as
    the wall cells agreement() counts wrong; the PNG holds the same picture."""
    from deploy.stack.png import write_png
    from testkit.webrig import rgb  # Pillow's decoder (it checks each chunk's CRC): not ours read back by ours

    truth = WorldTruth.of("room", START, 0.05)
    red, black = (230, 0, 0), (0, 0, 0)

    def count(img, colour):
        return int(np.all(img == colour, axis=2).sum())

    right = truth.picture(truth_map)
    assert right.shape == truth.dist.shape + (3,) and count(right, red) == 0 and count(right, black) > 100
    shifted = dataclasses.replace(truth_map, data=np.roll(truth_map.data, 10, axis=1))
    img = truth.picture(shifted)
    walls, _ = truth.agreement(shifted)
    occupied = int((shifted.data >= 65).sum())
    assert count(img, red) == pytest.approx((1 - walls) * occupied, abs=2)  # one world cell per map cell here
    write_png(tmp_path / "walls.png", img)
    assert np.array_equal(rgb((tmp_path / "walls.png").read_bytes()), img)
    with pytest.raises(ValueError, match="rows, cols, 3"):
        write_png(tmp_path / "bad.png", img[..., 0])
