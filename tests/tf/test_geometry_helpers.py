"""The shared planar helpers of common/geometry.py: footprint radii, point in polygon, turn counting, a turn
about a point off base_link."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.geometry import Pose2D, TurnCounter, footprint_radii, pivoted, points_in_polygon

P3AT = np.array([[0.3302, -0.0508], [0.254, -0.0508], [0.254, -0.254], [-0.254, -0.254], [-0.254, 0.254],
                 [0.254, 0.254], [0.254, 0.0508], [0.3302, 0.0508]])


def test_footprint_radii_of_the_p3at_and_a_square():
    inscribed, circumscribed = footprint_radii(P3AT)
    assert inscribed == pytest.approx(0.254)
    assert circumscribed == pytest.approx(math.hypot(0.254, 0.254))
    assert footprint_radii(np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])) == \
        pytest.approx((1.0, math.sqrt(2.0)))
    assert footprint_radii(np.zeros((0, 2))) == (0.0, 0.0)


def test_points_in_polygon_follows_the_even_odd_rule_on_a_concave_footprint():
    x = np.array([0.0, 0.30, 0.30, 0.20, -0.3])
    y = np.array([0.0, 0.0, 0.10, 0.20, 0.0])
    assert points_in_polygon(x, y, P3AT).tolist() == [True, True, False, True, False]
    grid = points_in_polygon(np.zeros((2, 3)), np.zeros((2, 3)), P3AT)
    assert grid.shape == (2, 3) and grid.all()


def test_turn_counter_adds_every_turn_across_the_wrap_and_restarts_on_reset():
    c = TurnCounter()
    assert c.add(3.0) == 0.0  # the first heading only sets where counting starts
    assert c.add(-3.0) == pytest.approx(2 * math.pi - 6.0)  # across +-pi: the short way
    assert c.add(-2.0) == pytest.approx(2 * math.pi - 5.0)
    assert c.add(-3.0) == pytest.approx(2 * math.pi - 4.0)  # turning back counts too
    c.reset()
    assert c.add(1.0) == 0.0 and c.turned == 0.0


def test_pivoted_is_the_turn_about_the_point_and_exact_for_a_constant_twist():
    """A base that turns about (c, 0) while its odometry integrates about base_link: a turn in place by a is the
    rotation about that point, and a constant (v, w) split into many steps gives what one step gives (the
    correction is linear in the twist), so a driver may apply it at any rate."""
    c, a = -0.12, 1.1
    turned = pivoted(Pose2D(0.0, 0.0, a), c)
    centre = np.array([c, 0.0])  # base_link's origin turned by a about the centre
    expected = centre + np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]) @ -centre
    assert [turned.x, turned.y] == pytest.approx(expected.tolist(), abs=1e-12) and turned.theta == a
    v, w, t, n = 0.3, 0.8, 2.0, 200
    def arc(s):  # base_link's motion over s seconds as wheel odometry integrates it
        return Pose2D(v / w * math.sin(w * s), v / w * (1 - math.cos(w * s)), w * s)
    whole, steps = pivoted(arc(t), c), Pose2D()
    for _ in range(n):
        steps = steps.compose(pivoted(arc(t / n), c))
    assert steps.as_array() == pytest.approx(whole.as_array(), abs=1e-9)
    assert pivoted(arc(t), 0.0) == arc(t)
