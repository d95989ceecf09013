"""``zenav robot --config robot_side/config/jackal_sim.yaml`` as a subprocess (the simulated BARN Jackal in
its default world, barn_demo): front/scan, a world-aligned odom, tf, ground_truth, collision and clock."""

from __future__ import annotations

import math
import shutil
import sys

import numpy as np
import pytest

from common.messages import LaserScan
from common.tf import TFListener
from robot_side.sim.base import base_preset
from robot_side.worlds import barn
from tests.sim_e2e.conftest import REPO, Recorder, wait_until
from tests.sim_e2e.e2e_checks import Rig

CONFIG = REPO / "robot_side" / "config" / "jackal_sim.yaml"
JACKAL = base_preset("jackal")
HALF_LENGTH = max(x for x, _ in JACKAL.footprint)


def zenav() -> list[str]:
    exe = shutil.which("zenav")
    return [exe] if exe else [sys.executable, "-m", "deploy.cli"]


@pytest.fixture
def jackal(bus, procs, robot_name):
    node, env = bus
    scan = Recorder(node, "front/scan", LaserScan)
    plain_scan = Recorder(node, "scan", LaserScan)
    proc = procs([*zenav(), "robot", "--config", str(CONFIG), "--robot", robot_name], env)
    return Rig(node, proc, timeout=120.0), scan, plain_scan


def _beam(scan: LaserScan, angle: float) -> float:
    return float(scan.ranges[round((angle - scan.angle_min) / scan.angle_increment)])


def test_jackal_config_publishes_front_scan_world_aligned_odom_and_truth(bus, jackal):
    node, _ = bus
    rig, scan, plain_scan = jackal
    tf = TFListener(node)
    s = wait_until(lambda: len(scan) >= 20 and scan.last(), 60, "20 scans on front/scan")
    assert s.header.frame_id == "front_laser"
    assert len(s.ranges) == 720
    assert (s.angle_min, s.angle_max, s.range_min, s.range_max) == pytest.approx((-2.35619, 2.35619, 0.1, 30.0))
    # 50 Hz of sim time: every stamp on the 0.02 s grid. A stream message may be dropped on the way on a
    # loaded machine (Zenoh's drop congestion control, README "Reliability"); the simulator skips none.
    k = np.diff([m.header.stamp for m in scan.msgs()]) / 0.02
    assert np.allclose(k, np.round(k), atol=1e-4) and np.all(np.round(k) >= 1), k
    assert np.mean(np.round(k) == 1) >= 0.9, f"over 10 % of the scans lost: {k}"
    assert len(plain_scan) == 0, "the Jackal's laser is on front/scan only"
    # the side walls of the BARN box, 2.1 m to the left and right of the start (cylinder faces)
    for side in (math.pi / 2, -math.pi / 2):
        assert _beam(s, side) == pytest.approx(2.1, abs=0.03)
    # ground truth at the BARN start; odometry at (0, 0) with the start's yaw (world-aligned odom)
    g, o = rig.gt.msgs()[0].pose2d, rig.odom.msgs()[0].pose2d
    assert (g.x, g.y, g.theta) == pytest.approx(barn.START, abs=1e-6)
    assert (o.x, o.y, o.theta) == pytest.approx((0.0, 0.0, barn.START[2]), abs=1e-6)
    laser = tf.buffer.lookup("base_link", "front_laser", timeout=30.0).transform
    assert laser.apply(np.zeros((1, 3)))[0] == pytest.approx([0.055, 0.0, 0.31], abs=1e-9)
    odom_tf = tf.buffer.lookup("odom", "base_link", timeout=30.0).transform.to_pose2d()
    assert odom_tf.theta == pytest.approx(barn.START[2], abs=1e-3)
    assert rig.now() > 0
    assert "laser 'front_laser' on front/scan 720 beams" in rig.proc.log()


def test_jackal_backing_into_the_box_wall_collides_and_odom_follows_the_world_axes(bus, jackal):
    rig, _, _ = jackal
    rig.drive([(30.0, -1.0, 0.0)], until=lambda: len(rig.collision) > 0)
    hit = wait_until(rig.collision.last, 30, "a collision message")
    assert hit.count >= 1
    rig.wait_stopped()
    g = rig.gt.last().pose2d
    wall_face = 0.075 + barn.CYLINDER_RADIUS  # the back wall of cylinders at y = 0.075
    assert g.y - HALF_LENGTH >= wall_face - barn.RESOLUTION
    assert g.y - HALF_LENGTH <= wall_face + 0.1
    assert abs(hit.y - wall_face) <= 0.05
    # world-aligned odometry: odom = world pose - start position, same heading (within the noise model)
    odom = {round(m.header.stamp, 6): m.pose2d for m in rig.odom.msgs()}
    gt = {round(m.header.stamp, 6): m.pose2d for m in rig.gt.msgs()}
    t = max(set(odom) & set(gt))
    o, g = odom[t], gt[t]
    dist = barn.START[1] - g.y
    assert dist > 2.0
    tol = 4 * (JACKAL.srr * math.sqrt(dist) + dist * JACKAL.str * math.sqrt(dist))
    assert o.x == pytest.approx(g.x - barn.START[0], abs=tol)
    assert o.y == pytest.approx(g.y - barn.START[1], abs=tol)
    assert math.remainder(o.theta - g.theta, 2 * math.pi) == pytest.approx(0.0, abs=4 * JACKAL.str * math.sqrt(dist))
