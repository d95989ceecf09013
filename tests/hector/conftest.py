"""Helpers for the hector tests: a synthetic room, its scans, and maps built from them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import Header, LaserScan
from master_side.hector.params import HectorParams
from master_side.hector.slam import make_levels
from tests.slam.conftest import _room_scan, ray_ranges

PARAMS = HectorParams(map_resolution=0.05, map_size=256, map_multi_res_levels=3, laser_min_dist=0.05,
                      laser_max_dist=20.0)


def room_levels(truth: Pose2D, params: HectorParams = PARAMS, passes: int = 3):
    """The multi-resolution map of the synthetic room seen from ``truth`` (a few identical scans)."""
    from master_side.hector.slam import HectorSlam

    levels = make_levels(params)
    helper = HectorSlam(params)
    pts = helper.scan_points(_room_scan(truth))
    for _ in range(passes):
        for lv in levels:
            lv.update(truth.as_array()[:2], truth.apply(pts))
    return levels, helper


@pytest.fixture
def room_scan():
    return _room_scan


def segment_scan(pose: Pose2D, segments, n: int = 181, fov: float = math.pi, max_range: float = 30.0) -> LaserScan:
    """A scan over ``fov`` (a SICK-like 180° by default) of world line ``segments`` ((x0, y0), (x1, y1));
    beams hitting nothing within ``max_range`` return max_range + 1 (dropped as "no return")."""
    inc = fov / (n - 1)
    best = ray_ranges(pose, -fov / 2 + inc * np.arange(n) + pose.theta, segments)
    best[best > max_range] = max_range + 1.0
    return LaserScan(Header(0.0, "laser"), -fov / 2, fov / 2, inc, 0.0, 0.0, 0.05, max_range,
                     best.astype(np.float32))


CORRIDOR = [((-40.0, -1.01), (40.0, -1.01)), ((-40.0, 1.01), (40.0, 1.01))]  # no end in range
