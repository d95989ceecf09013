"""zenav's stall_marks: the flank points a stalled command pushes outwards, and their sending once per stall."""

from __future__ import annotations

import math

import numpy as np
import pytest

from master_side.move_base.stall_marks import StallMarker, flank_push_points
from master_side.planning.local.scoring_context import footprint_outline

HALF_L, HALF_W, PAD = 0.3, 0.25, 0.04
BODY = np.array([(HALF_L, HALF_W), (-HALF_L, HALF_W), (-HALF_L, -HALF_W), (HALF_L, -HALF_W)])  # clockwise
PADDED = BODY + np.sign(BODY) * PAD


def turned(poly: np.ndarray, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return poly @ np.array([[c, s], [-s, c]])


def inside(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Points (N, 2) inside a convex polygon (either winding)."""
    edges = np.roll(poly, -1, axis=0) - poly
    cross = edges[None, :, 0] * (points[:, None, 1] - poly[None, :, 1]) \
        - edges[None, :, 1] * (points[:, None, 0] - poly[None, :, 0])
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


@pytest.mark.parametrize(("v", "w", "left_x_sign"), [(-0.10, -0.15, -1), (0.0, 1.0, +1), (0.2, 0.4, +1)])
def test_a_turn_marks_the_flank_halves_it_swings_outwards(v, w, left_x_sign):
    pts = flank_push_points(BODY, v, w)
    assert len(pts) >= 6 and pts.dtype == np.float32
    left, right = pts[pts[:, 1] > 0], pts[pts[:, 1] < 0]
    assert np.allclose(np.abs(pts[:, 1]), HALF_W + 0.08)  # beyond the flank, outside the 0.04 m padding
    # counter-clockwise (w > 0) swings the left flank's front half out and the right flank's rear half; clockwise
    # the other halves. The forward speed pushes no flank.
    assert np.all(np.sign(left[:, 0]) == left_x_sign) and np.all(np.sign(right[:, 0]) == -left_x_sign)
    assert np.all(np.abs(pts[:, 0]) < HALF_L)  # the corners belong to the bumpers' faces too: not marked twice


def test_the_marks_stop_the_stalled_turn_and_leave_the_opposite_one_free():
    """The point of the marks: turning the padded footprint 0.15 rad the stalled way reaches them (the wall
    the flank pushed on), the other way does not."""
    pts = flank_push_points(BODY, -0.10, -0.15)[:, :2]
    assert not inside(pts, PADDED).any()  # where the robot stands: free, so the obstacle layer keeps them
    assert inside(pts, turned(PADDED, -0.15)).any()
    assert not inside(pts, turned(PADDED, +0.15)).any()
    assert not inside(pts, PADDED + (0.1, 0.0)).any() and not inside(pts, PADDED - (0.1, 0.0)).any()


def test_straight_commands_mark_nothing_and_either_winding_gives_the_same_points():
    assert len(flank_push_points(BODY, 0.3, 0.0)) == 0
    assert len(flank_push_points(BODY, -0.1, 0.0)) == 0
    a, b = flank_push_points(BODY, 0.1, 0.5), flank_push_points(BODY[::-1], 0.1, 0.5)
    assert np.allclose(np.sort(a, axis=0), np.sort(b, axis=0))
    # a many-sided footprint too (the outline's points as its vertices)
    round_ish = footprint_outline(BODY, 0.1)
    assert len(flank_push_points(round_ish, 0.0, 1.0)) > 0


def test_the_marker_sends_each_new_stall_once_an_empty_cloud_a_second_later_and_keeps_the_topic_alive():
    sent: list[tuple[int, float]] = []
    marker = StallMarker(BODY, lambda pts, t: sent.append((len(pts), t)))
    marker.tick(0.0, 0, None)
    assert sent == [(0, 0.0)]  # an empty cloud at once: the costmap hears the source
    marker.tick(0.5, 0, None)
    marker.tick(1.0, 0, None)
    assert sent == [(0, 0.0), (0, 1.0)]  # and every second
    sent.clear()
    marker.tick(1.1, 1, (-0.1, 0.0, -0.15))  # a stall
    marker.tick(1.2, 1, (-0.1, 0.0, -0.15))  # the same stall, a cycle later: nothing new
    marker.tick(2.05, 1, (-0.1, 0.0, -0.15))
    assert len(sent) == 1 and sent[0][0] > 0
    marker.tick(2.1, 1, (-0.1, 0.0, -0.15))  # a second after: the empty cloud
    assert sent[-1] == (0, 2.1)
    marker.tick(2.5, 1, (-0.1, 0.0, -0.15))
    assert len(sent) == 2
    marker.tick(2.6, 2, (0.3, 0.0, 0.0))  # a straight stall: the bumpers' business, no marks
    assert all(n == 0 for n, _ in sent[2:])


def test_a_base_turning_about_a_point_behind_base_link_pushes_its_flank_from_that_point_on():
    """A turn pushes a flank outwards ahead of the point the base turns about: base_link for a differential
    drive, 0.12 m behind it for the P3-AT on physics (the local planner's rotation_center_x)."""
    square = np.array([[0.25, 0.25], [-0.25, 0.25], [-0.25, -0.25], [0.25, -0.25]])
    about_base = flank_push_points(square, 0.0, 1.0, spacing=0.02)
    pivoted = flank_push_points(square, 0.0, 1.0, spacing=0.02, center_x=-0.12)
    left = lambda pts: pts[pts[:, 1] > 0]  # noqa: E731  (a left turn pushes the left flank's front part)
    assert left(about_base)[:, 0].min() > 0.0
    assert -0.12 < left(pivoted)[:, 0].min() < 0.0
