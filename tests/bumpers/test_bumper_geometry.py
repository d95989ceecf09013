"""Bumpers (robot_side/bumpers/geometry.py): which segment a contact presses, the points a press becomes, and
that those points stay in a local costmap that clears the cells under the robot's padded footprint."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.cost_values import LETHAL
from master_side.costmap.costmap2d import Costmap2D
from master_side.costmap.footprint import pad_footprint
from master_side.costmap.layered import LayeredCostmap
from robot_side.bumpers.geometry import BumperParams, PressLatch, press_points, pressed

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "costmap"))
from costmap_helpers import obstacle_layer  # noqa: E402

P3AT = BumperParams()  # the P3-AT: faces at +-0.254 m, 0.508 m wide, 5 segments each
FOOTPRINT = np.array([[0.3302, -0.0508], [0.254, -0.0508], [0.254, -0.254], [-0.254, -0.254], [-0.254, 0.254],
                      [0.254, 0.254], [0.254, 0.0508], [0.3302, 0.0508]])  # the tutorial's


def test_a_contact_presses_the_segment_it_touches_numbered_from_the_left():
    assert pressed(P3AT, (0.26, 0.25)) == ((True, False, False, False, False), (False,) * 5)  # front left end
    assert pressed(P3AT, (0.25, 0.0))[0] == (False, False, True, False, False)  # front middle
    # office02's contact: the rear right corner, touched while turning
    assert pressed(P3AT, (-0.25, -0.26)) == ((False,) * 5, (False, False, False, False, True))
    assert pressed(P3AT, (0.0, 0.26)) == ((False,) * 5, (False,) * 5)  # a flank: no bumper there
    assert pressed(P3AT, None) == ((False,) * 5, (False,) * 5)


def test_a_press_is_latched_until_read_so_a_step_between_two_reports_is_not_missed():
    latch = PressLatch(P3AT)
    latch.note((-0.25, -0.26))
    latch.note((0.25, 0.0))
    assert latch.take() == ((False, False, True, False, False), (False, False, False, False, True))
    assert latch.take() == ((False,) * 5, (False,) * 5)


def test_press_points_lie_beyond_the_pressed_segment_and_outside_the_padded_footprint():
    rear_right = (False, False, False, False, True)
    pts = press_points(P3AT, (False,) * 5, rear_right, offset=0.08, z=0.1)
    assert pts.dtype == np.float32 and pts.shape[1] == 3 and np.all(pts[:, 2] == np.float32(0.1))
    behind = pts[pts[:, 0] < -0.3]
    assert len(behind) == 3 and np.allclose(behind[:, 0], -0.334) and np.all(behind[:, 1] <= -0.15)
    assert np.any(np.isclose(pts[:, 1], -0.334))  # beside the corner too
    assert len(press_points(P3AT, (False,) * 5, (False,) * 5)) == 0


def test_a_press_marks_the_local_costmap_and_survives_its_footprint_clearing():
    lc = LayeredCostmap(Costmap2D(110, 110, 0.025, -1.375, -1.375), rolling_window=True,
                        footprint=pad_footprint(FOOTPRINT, 0.04))
    layer = obstacle_layer(lc, footprint_clearing=True, data_type="PointCloud", clearing=False,
                           min_obstacle_height=0.0)
    robot = Pose2D(0.0, 0.0, 0.3)
    pts = press_points(P3AT, (False,) * 5, (False, False, False, False, True)).astype(float)
    world = np.column_stack((robot.apply(pts[:, :2]), pts[:, 2]))
    layer.add_observation("scan", world, np.array([robot.x, robot.y, 0.1]), 0.0)
    lc.update_map(robot)
    marked = [lc.master.get_cost(x, y) == LETHAL for x, y in world[:, :2]]
    assert all(marked), marked
