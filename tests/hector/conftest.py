"""Helpers for the hector tests: a synthetic room, its scans, and maps built from them."""

from __future__ import annotations

import pytest

from common.geometry import Pose2D
from master_side.hector.params import HectorParams
from master_side.hector.slam import make_levels
from tests.slam.conftest import _room_scan

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
