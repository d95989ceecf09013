import math

import numpy as np
import pytest

from master_side.slam.evaluate import evaluate, read_relations
from master_side.slam.logs import read_bag, read_carmen


@pytest.fixture(scope="module")
def slam_dir(shared_dir):
    return shared_dir / "datasets" / "slam"


def _first(it, n):
    out = []
    for rec in it:
        out.append(rec)
        if len(out) == n:
            break
    return out


def test_carmen_and_bag_readers_agree_on_the_first_scans(slam_dir):
    clf = _first(read_carmen(slam_dir / "aces.recon.clf"), 200)
    bag = _first(read_bag(slam_dir / "ros1_bags" / "aces.orig.bag"), 200)
    for a, b in zip(clf, bag):
        assert a.stamp == pytest.approx(b.stamp, abs=1e-6)
        assert np.allclose(a.scan.ranges, b.scan.ranges, atol=0.006)
        assert a.odom.distance(b.odom) < 2e-3
        assert abs(math.remainder(a.odom.theta - b.odom.theta, 2 * math.pi)) < 2e-3
        assert a.scan.angle_min == pytest.approx(-math.pi / 2)
        assert b.scan.angle_min == pytest.approx(-math.pi / 2)
        assert len(a.scan.ranges) == len(b.scan.ranges) == 180


def test_flaser_beams_use_the_carmen_one_degree_geometry(slam_dir):
    rec = _first(read_carmen(slam_dir / "aces.recon.clf"), 1)[0]
    ang = rec.scan.angles()
    assert ang[0] == pytest.approx(-math.pi / 2)
    assert ang[1] - ang[0] == pytest.approx(math.pi / 180)


def test_odometry_baseline_on_aces_matches_the_published_numbers(slam_dir):
    recs = list(read_carmen(slam_dir / "aces.recon.clf"))
    stamps = np.array([r.stamp for r in recs])
    poses = np.array([r.odom.as_array() for r in recs])
    s = evaluate(stamps, poses, read_relations(slam_dir / "aces.relations")).summary()
    assert s["relations"] == 1279
    assert s["trans_mean_m"] == pytest.approx(0.549, rel=0.01)
    assert s["trans_std_m"] == pytest.approx(2.681, rel=0.01)
    assert s["rot_mean_deg"] == pytest.approx(2.2, rel=0.03)
