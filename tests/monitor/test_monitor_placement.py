"""Where the monitor draws what moves (issue 31), read back from a real .rrd:

  - a scan is placed with the transform at *its* stamp, in the fixed frame (odom), as rviz does, not in its
    own frame (where Rerun would move it with the newest transform: a scan taken before a turn was drawn
    turned with the robot, a line of points metres outside the room);
  - the odometry trail starts again when odometry restarts (its node in a new process, as in the demo's next
    world, or a simulated clock going back): the old trail is cleared, not joined to the new one.
"""

from __future__ import annotations

import math

import numpy as np
import rerun as rr
from monhelp import read_rrd

from common import messages as m
from common.geometry import Pose2D, Transform, Vector3
from deploy.monitor.monitor import Monitor


def tf(stamp: float, parent: str, child: str, pose: Pose2D) -> m.TFMessage:
    return m.TFMessage((m.TransformStamped(m.Header(stamp, parent), child, pose.to_transform()),))


def recording(tmp_path, name: str) -> tuple[rr.RecordingStream, Monitor]:
    rec = rr.RecordingStream(f"zenav_test_{name}")
    rec.save(str(tmp_path / f"{name}.rrd"))
    return rec, Monitor(None, "r1", rec, subscribe=False, rates={"LaserScan": 0, "TFMessage": 0, "Odometry": 0})


def close(rec, mon, tmp_path, name: str) -> dict:
    mon.flush_pending(flush_all=True)
    rec.flush()
    rec.disconnect()
    return read_rrd(tmp_path / f"{name}.rrd")


def test_a_scan_is_drawn_with_the_transform_at_its_stamp_in_the_odom_frame(tmp_path):
    rec, mon = recording(tmp_path, "scan_stamp")
    mon.handle("tf_static", m.TFMessage((m.TransformStamped(m.Header(0.0, "base_link"), "laser",
                                                            Transform(Vector3(0.1, 0.0, 0.0))),)))
    mon.handle("tf", tf(1.0, "odom", "base_link", Pose2D(0.0, 0.0, 0.0)))
    mon.handle("tf", tf(2.0, "odom", "base_link", Pose2D(1.0, 0.0, math.pi / 2)))  # then it turned
    one_beam = np.array([2.0], np.float32)  # straight ahead, 2 m
    mon.handle("scan", m.LaserScan(m.Header(1.0, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0,
                                   ranges=one_beam))
    mon.handle("scan", m.LaserScan(m.Header(1.5, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0,
                                   ranges=one_beam))  # between: interpolated, half the turn
    rows = [r for r in close(rec, mon, tmp_path, "scan_stamp")["/world/scan"] if r.get("Points3D:positions")]
    assert [r["CoordinateFrame:frame"][0] for r in rows] == ["odom", "odom"]
    first, between = (np.array(r["Points3D:positions"][0]) for r in rows)
    assert np.allclose(first, [2.1, 0.0, 0.0], atol=1e-4), first  # the pose at 1.0, not the newest
    yaw = math.pi / 4
    want = [0.5 + 2.1 * math.cos(yaw), 2.1 * math.sin(yaw), 0.0]
    assert np.allclose(between, want, atol=1e-3), (between, want)


def test_a_scan_that_arrives_before_the_odometry_of_its_instant_waits_for_it(tmp_path):
    rec, mon = recording(tmp_path, "scan_waits")
    mon.handle("tf", tf(1.0, "odom", "laser", Pose2D(0.0, 0.0, 0.0)))
    beam = np.array([2.0], np.float32)
    mon.handle("scan", m.LaserScan(m.Header(1.5, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0, ranges=beam))
    mon.flush_pending()  # not logged yet: TF ends at 1.0
    assert mon.stats.by_entity.get("world/scan", 0) == 0
    mon.handle("tf", tf(2.0, "odom", "laser", Pose2D(1.0, 0.0, 0.0)))
    mon.flush_pending()  # now it is
    assert mon.stats.by_entity.get("world/scan", 0) == 1
    mon.handle("scan", m.LaserScan(m.Header(9.0, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0, ranges=beam))
    mon.flush_pending()  # waits (at most PLACE_WAIT_S; close() flushes everything)
    assert mon.stats.by_entity.get("world/scan", 0) == 1
    rows = [r for r in close(rec, mon, tmp_path, "scan_waits")["/world/scan"] if r.get("Points3D:positions")]
    placed = {r["CoordinateFrame:frame"][0]: np.array(r["Points3D:positions"][0]) for r in rows}
    assert np.allclose(placed["odom"], [2.5, 0.0, 0.0], atol=1e-4), placed  # halfway, 1.5 between 1.0 and 2.0
    assert np.allclose(placed["laser"], [2.0, 0.0, 0.0]), placed  # 9.0: TF never got there, drawn as it is


def test_a_scan_before_its_sensors_static_transform_waits_for_it(tmp_path):
    """A playback's first scans can arrive before the laser's latched static transform: placed in their own
    frame then, they differed from the live run's at equal stamps (ci108)."""
    rec, mon = recording(tmp_path, "scan_static_later")
    mon.handle("tf", tf(1.0, "odom", "base_link", Pose2D(0.0, 0.0, 0.0)))
    mon.handle("tf", tf(2.0, "odom", "base_link", Pose2D(0.0, 0.0, 0.0)))
    mon.handle("scan", m.LaserScan(m.Header(1.5, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0,
                                   ranges=np.array([2.0], np.float32)))
    mon.flush_pending()
    assert mon.stats.by_entity.get("world/scan", 0) == 0  # odom is known, the laser not yet connected to it
    mon.handle("tf_static", m.TFMessage((m.TransformStamped(m.Header(0.0, "base_link"), "laser",
                                                            Transform(Vector3(0.1, 0.0, 0.0))),)))
    mon.flush_pending()
    row = next(r for r in close(rec, mon, tmp_path, "scan_static_later")["/world/scan"] if r.get("Points3D:positions"))
    assert row["CoordinateFrame:frame"] == ["odom"]
    assert np.allclose(row["Points3D:positions"][0], [2.1, 0.0, 0.0], atol=1e-4)


def test_a_scan_without_its_transform_yet_is_drawn_in_its_own_frame(tmp_path):
    rec, mon = recording(tmp_path, "scan_no_tf")
    mon.handle("scan", m.LaserScan(m.Header(1.0, "laser"), 0.0, 0.0, 0.1, range_min=0.1, range_max=5.0,
                                   ranges=np.array([2.0], np.float32)))
    row = next(r for r in close(rec, mon, tmp_path, "scan_no_tf")["/world/scan"] if r.get("Points3D:positions"))
    assert row["CoordinateFrame:frame"] == ["laser"]
    assert np.allclose(row["Points3D:positions"][0], [2.0, 0.0, 0.0])


def drive(mon: Monitor, stamps, xs) -> None:
    for t, x in zip(stamps, xs):
        mon.handle("odom", m.Odometry(m.Header(t, "odom"), "base_link", Pose2D(x, 0.0, 0.0).to_transform()),
                   sender="sim")
        mon.flush_pending(flush_all=True)


def test_the_trail_starts_again_when_odometry_restarts(tmp_path):
    rec, mon = recording(tmp_path, "trail_restart")

    def state(node: str, pid: int, t: float) -> None:
        mon.handle("agent/robot/state", m.NodeState(m.Header(t), node, "RUNNING", pid))

    state("sim", 100, 0.5)
    drive(mon, [1.0, 1.1, 1.2], [0.0, 0.1, 0.2])
    state("depth_to_scan", 101, 1.25)  # another node: nothing to do with odometry
    state("sim", 100, 1.25)  # the same process
    drive(mon, [1.3, 1.4], [0.3, 0.4])  # the same trail
    state("sim", 200, 4.0)  # the odometry's node in a new process (the demo's next world, a driver restarted)
    drive(mon, [5.0, 5.1], [0.0, 0.1])
    drive(mon, [0.5, 0.6], [5.0, 5.1])  # back in time: a simulated clock started again
    rows = close(rec, mon, tmp_path, "trail_restart")
    strips = {e: [r["LineStrips3D:strips"] for r in rs if r.get("LineStrips3D:strips") is not None]
              for e, rs in rows.items() if e.startswith("/world/odom_trail/")}
    drawn = {e: [np.array(v[0])[:, 0].round(2).tolist() for v in s if v] for e, s in strips.items()}
    assert {e: d[-1] for e, d in drawn.items()} == {
        "/world/odom_trail/0": [0.0, 0.1, 0.2, 0.3, 0.4], "/world/odom_trail/1": [0.0, 0.1],
        "/world/odom_trail/2": [5.0, 5.1]}, drawn
    # each restart empties every older segment (in its frame, so Rerun still places it): 0 twice, 1 once
    assert {e: sum(1 for v in s if not v) for e, s in strips.items()} == {
        "/world/odom_trail/0": 2, "/world/odom_trail/1": 1, "/world/odom_trail/2": 0}
    assert all(r.get("CoordinateFrame:frame") == ["odom"] for e, rs in rows.items()
               if e.startswith("/world/odom_trail/") for r in rs if r.get("LineStrips3D:strips") is not None)


def test_a_scan_whose_frame_is_not_connected_yet_waits_longer_than_one_ahead_of_tf():
    """A loaded machine can deliver the sensor's latched static transform seconds after the first scans (a CI
    run: more than 0.5 s): such a scan waits CONNECT_WAIT_S, one merely ahead of the odometry PLACE_WAIT_S."""
    from deploy.monitor.placement import CONNECT_WAIT_S, PLACE_WAIT_S, Placement

    now = [100.0]
    pl = Placement(clock=lambda: now[0])
    pl.remember(tf(1.0, "odom", "base_link", Pose2D(0.0, 0.0, 0.0)), static=False)
    done: list[str] = []
    pl.place("scan", m.Header(1.0, "laser"), lambda: done.append("unconnected"))
    pl.place("cloud", m.Header(5.0, "base_link"), lambda: done.append("ahead"))
    assert done == []
    now[0] += PLACE_WAIT_S + 0.1
    for submit in pl.due():
        submit()
    assert done == ["ahead"]  # drawn as it is: TF did not reach its stamp in time
    now[0] += CONNECT_WAIT_S - PLACE_WAIT_S - 0.2
    assert pl.due() == []  # still waiting for the laser's static transform
    pl.remember(m.TFMessage((m.TransformStamped(m.Header(0.0, "base_link"), "laser",
                                                Transform(Vector3(0.1, 0.0, 0.0))),)), static=True)
    for submit in pl.due():
        submit()
    assert done == ["ahead", "unconnected"]
    assert pl.at_stamp(m.Header(1.0, "laser")) is not None  # and now it can be placed
