"""Issue 3 acceptance against ``python -m robot_side.sim.node`` driven from a separate Zenoh peer."""

from __future__ import annotations

import math
import time

import numpy as np

from common.geometry import OPTICAL_FROM_LINK
from common.messages import (
    BatteryState,
    BumperState,
    CameraInfo,
    Clock,
    DepthImage,
    LaserScan,
    MotorState,
    Odometry,
    SonarArray,
)
from common.tf import TFListener
from robot_side.sim.base import BaseParams
from tests.sim_e2e.conftest import Recorder, open_world, publisher_matched, wait_until
from tests.sim_e2e.e2e_checks import (
    Rig,
    check_odom_tf_ground_truth_agree,
    check_stale_cmd_vel_stops,
    check_wall_collision,
)

NOISY = {"srr": 0.05, "srt": 0.05, "str": 0.05, "stt": 0.05, "seed": 3}


def test_odom_tf_and_ground_truth_agree_within_the_error_model(bus, sim, tmp_path):
    node, _ = bus
    proc = sim({"world": str(open_world(tmp_path)), "speed": 2.0, "base": NOISY})
    rig = Rig(node, proc)
    tf = TFListener(node)
    check_odom_tf_ground_truth_agree(rig, tf, BaseParams(**NOISY))


def test_stale_cmd_vel_stops_the_robot_within_the_timeout_in_sim_time(bus, sim, tmp_path):
    node, _ = bus
    base = {"cmd_vel_timeout": 0.5, "acc_lim_x": 1000.0, "acc_lim_th": 1000.0}
    proc = sim({"world": str(open_world(tmp_path)), "speed": 1.0, "base": base})
    check_stale_cmd_vel_stops(Rig(node, proc), BaseParams(**base))


def test_driving_into_a_wall_reports_a_collision_and_never_goes_through(bus, sim, tmp_path):
    node, _ = bus
    bumpers = Recorder(node, "bumper_state", BumperState)
    sonar = Recorder(node, "sonar", SonarArray)
    proc = sim({"world": str(open_world(tmp_path, wall_x=1.5)), "speed": 2.0, "bumper_rate": 10.0, "sonar": {}})
    check_wall_collision(Rig(node, proc), wall_x=1.5, resolution=0.05)
    # the bumpers, as a P2OS SIP reports them: the front's middle segment pressed while it pushed, and nothing
    # once it stood still (each report holds the presses since the last)
    wait_until(lambda: (b := bumpers.last()) is not None and not any(b.front_bumpers), 10, "the bumper released")
    states = bumpers.msgs()
    assert any(b.front_bumpers == (False, False, True, False, False) and not any(b.rear_bumpers) for b in states)
    # the front sonars heard the wall close in: 1.25 m ahead of them at the start, within a few cm at contact
    ahead = [min(m.ranges[3], m.ranges[4]) for m in sonar.msgs()]
    assert len(ahead) > 10 and ahead[0] > 1.0 and min(ahead) < 0.1, ahead[:3] + ahead[-3:]


def test_speed_5_runs_ten_sim_seconds_faster_than_real_time_and_never_above_5x(bus, sim, tmp_path):
    node, _ = bus
    clock = Recorder(node, "clock", Clock)
    odom = Recorder(node, "odom", Odometry)
    scan = Recorder(node, "scan", LaserScan)
    wall_start = time.time()
    proc = sim({"world": str(open_world(tmp_path)), "laser": {"rate": 25.0}}, "--speed", "5")
    wait_until(lambda: len(clock) and len(scan) or not proc.alive(), 90, "clock and scan")
    assert proc.alive(), proc.log()
    w0, c0 = clock.timed()[-1][0], clock.last().clock
    # sim time starts at the wall time at start (default start_time)
    assert wall_start - 1.0 <= c0 - 0.0 <= time.time() + 5 * (time.time() - wall_start) + 1.0
    w1 = wait_until(lambda: next((w for w, m in clock.timed() if m.clock >= c0 + 10.0), None), 60,
                    "10 s of sim time")
    # Two wall seconds when the cores are free; a loaded CI machine (two test workers beside it) took 4.2 s.
    # How fast is a benchmark's question (bench/sim.py); here: faster than real time, never beyond 5x.
    assert 1.2 < w1 - w0 < 8.0, f"10 sim seconds took {w1 - w0:.2f} wall seconds at --speed 5"
    assert "speed 5x" in proc.log()

    clocks = np.array([m.clock for m in clock.msgs() if m.clock <= c0 + 10.0])
    # from the first message on (not only after c0): a first reading off the grid is a bug
    odoms = np.array([m.header.stamp for m in odom.msgs() if m.header.stamp <= c0 + 10.0])
    scans = np.array([m.header.stamp for m in scan.msgs() if m.header.stamp <= c0 + 10.0])
    for name, s in (("clock", clocks), ("odom", odoms), ("scan", scans)):
        assert len(s) > 10, name
        assert np.all(np.diff(s) > 0), f"{name} stamps not strictly increasing"
    # one time base: every odom / scan stamp is a step of the clock's 0.01 s grid (a clock message may be
    # dropped on the way, see below, so not every stamp is a clock value this test received)
    for name, s in (("odom", odoms), ("scan", scans)):
        k = (s - clocks[0]) / 0.01
        assert np.allclose(k, np.round(k), atol=1e-3), f"{name} stamps off the clock's grid"
    # Stream topics use Zenoh's drop congestion control (README, Reliability): on a loaded machine a
    # message may be dropped on the way, but the simulator itself never skips a step of its grid.
    for name, s, step in (("clock", clocks, 0.01), ("odom", odoms, 0.02), ("scan", scans, 0.04)):
        k = np.diff(s) / step
        assert np.allclose(k, np.round(k), atol=1e-3) and np.all(np.round(k) >= 1), f"{name} off its grid"
        if name != "clock":
            assert np.mean(np.round(k) == 1) >= 0.9, f"{name}: over 10 % of the messages lost"
    # Faster than real time the clock goes out once per wake-up of the physics (10 ms of wall time, 5
    # steps at 5x), with the newest step's time, before that wake-up's messages: not for every step
    steps = (clocks[-1] - clocks[0]) / 0.01
    assert len(clocks) <= 0.5 * steps, f"{len(clocks)} clock messages for {steps:.0f} steps at 5x"


def test_disabled_motors_ignore_cmd_vel(bus, sim, tmp_path):
    node, _ = bus
    proc = sim({"world": str(open_world(tmp_path)), "speed": 2.0})
    rig = Rig(node, proc)
    motors = Recorder(node, "motor_state", MotorState)
    wait_until(lambda: motors.last() is not None and motors.last().enabled, 30, "motor_state enabled")
    pub = node.publisher("cmd_motor_state", reliable=True)  # a one-shot command: never dropped
    publisher_matched(pub)
    pub.publish(MotorState(enabled=False))
    wait_until(lambda: not motors.last().enabled, 30, "motor_state disabled")
    x0 = rig.gt.last().pose2d.x
    t0 = rig.now()
    rig.drive([(1.5, 0.5, 0.3)])
    moved = [m for m in rig.odom.msgs() if m.header.stamp > t0 and abs(m.twist.linear.x) > 0]
    assert not moved, "odom moved with the motors disabled"
    assert abs(rig.gt.last().pose2d.x - x0) < 1e-9, "moved with the motors disabled"
    # periodic motor_state (1 Hz sim time) keeps saying disabled
    n = len(motors)
    rig.wait_sim(1.2)
    assert len(motors) > n
    assert not motors.last().enabled
    pub.publish(MotorState(enabled=True))
    wait_until(lambda: motors.last().enabled, 30, "motor_state enabled again")
    # Drive until ground truth shows the move (a loaded machine may deliver the first commands late);
    # 10 s of sim time at 0.5 m/s is 5 m, so a robot still ignoring cmd_vel fails here.
    rig.drive([(10.0, 0.5, 0.0)], until=lambda: rig.gt.last().pose2d.x - x0 > 0.1)
    assert rig.gt.last().pose2d.x - x0 > 0.1, "cmd_vel ignored after re-enabling the motors"
    assert proc.stop() == 0, proc.log()  # SIGINT: clean shutdown


def test_sensor_frames_match_what_the_depth_nodes_look_up(bus, sim, tmp_path):
    node, _ = bus
    cam = {"depth_mode": 8, "x": 0.1, "z": 0.35}
    img = Recorder(node, "camera/depth/image", DepthImage)
    info = Recorder(node, "camera/depth/camera_info", CameraInfo)
    scan = Recorder(node, "scan", LaserScan)
    battery = Recorder(node, "battery_state", BatteryState)
    tf = TFListener(node)
    proc = sim({"world": str(open_world(tmp_path, wall_x=2.0)), "laser": {"model": "sick_s300"},
                "depth_camera": cam})
    wait_until(lambda: len(img) and len(info) and len(scan) and len(battery) or not proc.alive(), 90,
               "depth image, camera_info, scan and battery_state")
    assert proc.alive(), proc.log()
    image, ci, sc = img.last(), info.last(), scan.last()
    assert image.depth.shape == (120, 160)
    assert (ci.width, ci.height) == (160, 120)
    assert image.header.frame_id == ci.header.frame_id == "camera_depth_optical_frame"
    # the image's frame in base_link: level camera at the mount, optical axes (z forward, x right)
    t = tf.buffer.lookup("base_link", image.header.frame_id, image.header.stamp, timeout=10.0).transform
    want = np.array([[0.1, 0, 0.35], [0.1, 0, 1.35], [0.1, -1, 0.35]])  # origin, z, x of the optical frame
    got = t.apply(np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0]], float))
    assert np.allclose(got[0], want[0], atol=1e-6)
    assert np.allclose(got[1], [1.1, 0, 0.35], atol=1e-6)
    assert np.allclose(got[2], want[2], atol=1e-6)
    # depth_to_scan publishes in camera_depth_frame (x forward): level too
    d = tf.buffer.lookup("base_link", "camera_depth_frame", timeout=10.0).transform
    assert np.allclose(d.apply(np.array([[1.0, 0, 0]])), [[1.1, 0, 0.35]], atol=1e-6)
    optical = tf.buffer.lookup("camera_depth_frame", image.header.frame_id).transform
    assert np.allclose(optical.rotation.as_array(), OPTICAL_FROM_LINK.rotation.as_array(), atol=1e-9)
    # the laser at its mount; its straight-ahead beam sees the wall at 2.0 - 0.1 m
    assert sc.header.frame_id == "laser"
    assert len(sc.ranges) == 541
    lz = tf.buffer.lookup("base_link", "laser", timeout=10.0).transform
    assert np.allclose(lz.translation.as_array(), [0.1, 0, 0.35], atol=1e-6)
    assert abs(sc.ranges[270] - 1.9) < 0.06
    centre = image.depth[60, 75:85]
    assert np.all(np.abs(centre - 1.9) < 0.1), centre
    b = battery.last()
    assert 0.0 < b.percentage <= 1.0
    assert 11.0 <= b.voltage <= 12.8
    assert math.isfinite(image.header.stamp)
    assert abs(image.header.stamp - sc.header.stamp) < 1.0
