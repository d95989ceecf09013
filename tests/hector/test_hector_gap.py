"""A gap in the scans (aces has one of 3 s, in which the robot turned ~70° in place): the scan after
it is matched from the wider gap_search_* window too, and the better-fitting match is kept."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from common.geometry import Pose2D, normalize_angle
from master_side.hector.slam import HectorSlam
from tests.hector.conftest import PARAMS, segment_scan

ROOM = [((-4.0, -3.0), (4.0, -3.0)), ((4.0, -3.0), (4.0, 3.0)), ((4.0, 3.0), (-4.0, 3.0)),
        ((-4.0, 3.0), (-4.0, -3.0)), ((1.0, 0.5), (2.0, 0.5)), ((2.0, 0.5), (2.0, 1.2)),
        ((2.0, 1.2), (1.0, 1.2)), ((1.0, 1.2), (1.0, 0.5))]
BASE = replace(PARAMS, search_angular=0.5, search_angular_step=0.04, ignore_unknown=True, unknown_probability=0.0,
               velocity_window=5)


def _turn_then_gap(params, after: float) -> tuple[Pose2D, Pose2D]:
    """A SICK-like 180° scanner turns in place 0.05 rad per 0.2 s scan through 2π (the whole room mapped),
    then the next scan comes 3 s later, the robot having turned ``after`` rad more meanwhile.
    Returns (estimate, truth) of that scan."""
    slam = HectorSlam(params)
    start = Pose2D(-1.0, -0.5, 0.0)
    k, th = 0, 0.0
    while th < 2 * math.pi:
        slam.process(0.2 * k, segment_scan(Pose2D(start.x, start.y, th), ROOM))
        k, th = k + 1, th + 0.05
    truth = Pose2D(start.x, start.y, th - 0.05 + after)
    est = slam.process(0.2 * k + 3.0, segment_scan(truth, ROOM))
    return est, start.between(truth)


def _err(est: Pose2D, truth: Pose2D) -> tuple[float, float]:
    return math.hypot(est.x - truth.x, est.y - truth.y), abs(normalize_angle(est.theta - truth.theta))


def test_after_a_gap_in_the_scans_a_far_turn_is_found_by_the_wide_search():
    e_xy, e_th = _err(*_turn_then_gap(replace(BASE, gap_time=1.0), 1.6))
    assert e_xy < 0.05 and e_th < 0.02
    e_xy, e_th = _err(*_turn_then_gap(BASE, 1.6))  # hector's way: the ±0.5 rad window misses it
    assert e_th > 0.3


def test_after_a_gap_without_a_turn_the_local_match_is_kept():
    e_xy, e_th = _err(*_turn_then_gap(replace(BASE, gap_time=1.0), 0.0))
    assert e_xy < 0.05 and e_th < 0.02
    assert np.isclose(BASE.gap_time, 0.0)  # off by default, as hector
