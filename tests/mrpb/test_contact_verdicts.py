"""bench/contacts.py: a contact's snapshot read back into a verdict. Synthetic snapshots in the format
deploy/mrpb/contacts.py writes for the exploration and MRPB benches (tests/mrpb/test_contact_snapshot.py checks
that one over a real bus): a mark at the touched point that stays, that goes while the padded footprint covers it, that
goes while the robot is elsewhere, or that never was."""

from __future__ import annotations

import numpy as np
import pytest

from bench.contacts import MASTER, diagnose, local_footprint, part_of
from master_side.costmap.cost_values import LETHAL
from master_side.costmap.footprint import pad_footprint

RES, N = 0.025, 160  # a 4 m window centred on the odometry origin


def snapshot(point, marked_until: float | None, robot_x_before: float = 0.0, moved_at: float = -0.5) -> dict:
    """Maps every 0.1 s over the 3 s before a contact at t=10 s; the touched ``point`` (world = odometry
    frame here) marked in the maps stamped before ``marked_until`` (None: never); the robot at
    (``robot_x_before``, 0) until ``moved_at`` s before the contact, at the origin after."""
    stamp = 10.0
    ts = stamp + np.arange(-3.0, 0.01, 0.1)
    maps = np.zeros((len(ts), N, N), np.uint8)
    origin = (-N * RES / 2, -N * RES / 2)
    col, row = int((point[0] - origin[0]) / RES), int((point[1] - origin[1]) / RES)
    for k, t in enumerate(ts):
        if marked_until is not None and t - stamp < marked_until:
            maps[k, row, col] = LETHAL
    poses = np.array([(t, robot_x_before if t - stamp < moved_at else 0.0, 0.0, 0.0)
                      for t in stamp + np.arange(-4.0, 0.01, 0.05)])
    return {"point": np.array(point), "stamp": stamp, "maps": maps, "map_stamps": ts,
            "origins": np.array([origin] * len(ts)), "resolution": RES, "odom": poses, "truth": poses}


@pytest.fixture(scope="module")
def footprint():
    return local_footprint(MASTER)


def test_a_mark_freed_under_the_padded_footprint_is_footprint_clearing(footprint):
    padded, padding = footprint
    # beside the left flank, within the padding (the bare outline's flank is at 0.254 m)
    verdict, said, history = diagnose(snapshot((0.0, 0.27), marked_until=-1.0), padded, padding)
    assert verdict == "footprint_cleared", said
    assert "-1.0 s" in said or "-1.1 s" in said
    assert len(history) == 31 and history[0][1] < 0.05 and history[-1][1] == float("inf")


def test_a_mark_freed_while_the_robot_was_elsewhere_is_cleared(footprint):
    padded, padding = footprint
    verdict, said, _ = diagnose(snapshot((0.0, 0.27), marked_until=-1.0, robot_x_before=-2.0), padded, padding)
    assert verdict == "cleared", said


def test_a_mark_there_until_the_contact_and_one_never_there(footprint):
    padded, padding = footprint
    assert diagnose(snapshot((0.0, 0.27), marked_until=1.0), padded, padding)[0] == "marked"
    assert diagnose(snapshot((0.0, 0.27), marked_until=None), padded, padding)[0] == "never_marked"


def test_the_part_of_the_robot_that_touched(footprint):
    padded, padding = footprint
    bare = pad_footprint(padded, -padding)
    assert part_of(bare, np.array([0.0, 0.27])) == "left flank"
    assert part_of(bare, np.array([-0.26, -0.26])) == "rear-right corner"
    assert part_of(bare, np.array([0.34, 0.0])) == "front"
