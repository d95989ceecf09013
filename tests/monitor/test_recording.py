"""`zenav monitor --save` as a subprocess, fed by a synthetic robot in this process over loopback;
the .rrd is read back and checked entity by entity, including where the scan lands through TF."""

from __future__ import annotations

import signal
import subprocess
import sys

import numpy as np
import pytest
import rerun as rr
from monhelp import child_env, free_port, has_footer, read_rrd, values, wait_for

from common.bus import Node
from common.geometry import Quaternion, Transform, Vector3
from common.zenoh_config import BusConfig
from testkit import synthetic_monitor as syn

U8_L = rr.components.ImageFormat(width=1, height=1, color_model="L", channel_datatype="U8")


@pytest.fixture
def robot_bus(robot_name):
    """A synthetic robot publishing in this process (listening on a free loopback port)."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    node = Node("synthetic", config=BusConfig(robot=robot_name, multicast=False, listen=(ep,)))
    robot = syn.SyntheticRobot(node)
    published: dict[str, list] = {}
    pub = robot.pub

    def record(topic, msg, latched=False):
        published.setdefault(topic, []).append(msg)
        pub(topic, msg, latched)

    robot.pub = record
    robot.start()
    yield robot_name, ep, published
    robot.close()
    node.close()


def _monitor(tmp_path, robot, ep, *args):
    out = tmp_path / "run.rrd"
    argv = [sys.executable, "-m", "deploy.cli", "monitor", "--save", str(out), *args]
    return out, subprocess.Popen(argv, env=child_env(robot, ep), stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True, start_new_session=True)


def _tf(row) -> Transform:
    x, y, z, w = row["Transform3D:quaternion"][0]
    return Transform(Vector3(*row["Transform3D:translation"][0]), Quaternion(x, y, z, w))


def _one(rows, component):
    v = values(rows, component)
    assert v, f"no {component}"
    return v[-1][0]


def test_recording_has_every_display_in_its_frame(tmp_path, robot_bus):
    robot, ep, published = robot_bus
    out, proc = _monitor(tmp_path, robot, ep, "--duration", "8")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "malformed=0 errors=0" in err, err
    assert has_footer(out), "recording not closed properly (no footer)"
    rec = read_rrd(out)

    # Grids: the right cell size, format and frame.
    # the map is drawn cut to its known part and a cell around it (SLAM's big grids are mostly unknown)
    from deploy.monitor.loggers import known_part

    map_part, map_origin = known_part(syn.occupancy(), syn.MAP_ORIGIN, syn.RES)
    assert map_part.shape < syn.MAP_SHAPE
    grids = {"/world/map": (map_part.shape[1], map_part.shape[0], "map"),
             "/world/global_costmap/costmap": (240, 200, "map"),
             "/world/local_costmap/costmap": (80, 80, "odom"),
             "/world/local_costmap/costmap/obstacle_layer": (80, 80, "odom"),
             "/world/local_costmap/costmap/inflation_layer": (80, 80, "odom")}
    for entity, (w, h, frame) in grids.items():
        rows = rec.get(entity)
        assert rows, f"{entity} missing; have {sorted(rec)}"
        assert _one(rows, "GridMap:cell_size") == pytest.approx(syn.RES)
        fmt = _one(rows, "GridMap:format")
        assert (fmt["width"], fmt["height"]) == (w, h)
        assert fmt["color_model"] == U8_L.color_model.value
        assert fmt["channel_datatype"] == U8_L.channel_datatype.value
        assert len(_one(rows, "GridMap:data")) == w * h
        assert _one(rows, "CoordinateFrame:frame") == frame
    assert _one(rec["/world/map"], "GridMap:translation") == pytest.approx([map_origin.x, map_origin.y, 0.0])

    # Scan: one point per finite range, in the odom frame (placed with the transform at its stamp; in the
    # laser's own frame while TF does not have that stamp yet).
    expected = {int(np.isfinite(s.ranges).sum()) for s in published["scan"]}
    scans = values(rec["/world/scan"], "Points3D:positions")
    assert scans
    assert {len(p) for p in scans} <= expected
    scan_frames = [f[0] for f in values(rec["/world/scan"], "CoordinateFrame:frame")]
    assert set(scan_frames) <= {"odom", "laser"} and scan_frames.count("odom") > len(scan_frames) / 2, scan_frames

    # Plans, footprint (closed polygon), goal, cloud, depth image, trail.
    assert len(_one(rec["/world/move_base/global_plan"], "LineStrips3D:strips")) == 50
    assert _one(rec["/world/move_base/global_plan"], "CoordinateFrame:frame") == "map"
    assert len(_one(rec["/world/move_base/local_plan"], "LineStrips3D:strips")) == 10
    fp = np.array(_one(rec["/world/local_costmap/footprint"], "LineStrips3D:strips"))
    assert len(fp) == len(syn.FOOTPRINT) + 1
    assert np.allclose(fp[0], fp[-1])
    assert values(rec["/world/move_base/current_goal"], "Arrows3D:vectors")
    assert len(values(rec["/world/camera/depth/points"], "Points3D:positions")[-1]) == 800
    cloud_frames = [f[0] for f in values(rec["/world/camera/depth/points"], "CoordinateFrame:frame")]
    assert set(cloud_frames) <= {"odom", "camera_link"} and cloud_frames.count("odom") > len(cloud_frames) / 2
    depth_fmt = _one(rec["/camera/depth/image"], "DepthImage:format")
    assert (depth_fmt["width"], depth_fmt["height"]) == (80, 60)
    trail = [e for e in rec if e.startswith("/world/odom_trail/")]
    assert trail
    assert len(_one(rec[trail[0]], "LineStrips3D:strips")) >= 2
    # the trail is odom's alone, in its frame: the simulator's ground_truth (another Odometry stream, in the
    # map frame) once zigzagged into it, a smear of lines metres off the path (issue 31)
    odom_xy = np.array([(o.pose.translation.x, o.pose.translation.y) for o in published["odom"]])
    for e in trail:
        assert _one(rec[e], "CoordinateFrame:frame") == "odom"
        for strip in values(rec[e], "LineStrips3D:strips"):
            pts = np.array(strip[0])[:, :2]
            gap = np.min(np.hypot(pts[:, None, 0] - odom_xy[None, :, 0], pts[:, None, 1] - odom_xy[None, :, 1]), 1)
            assert gap.max() < 1e-3, f"{e}: a trail point {gap.max():.2f} m from every odom pose"
    speeds = values(rec["/plots/odom/speed"], "Scalars:scalars")
    assert speeds and len(speeds) <= len(published["odom"])

    # TF edges with ROS parent/child names; static ones without time.
    edges = {e: (_one(r, "Transform3D:parent_frame"), _one(r, "Transform3D:child_frame"))
             for e, r in rec.items() if e.startswith("/tf/")}
    assert edges == {"/tf/odom": ("map", "odom"), "/tf/base_link": ("odom", "base_link"),
                     "/tf/laser": ("base_link", "laser"), "/tf/camera_link": ("base_link", "camera_link")}
    assert all(r.get("stamp") is None for r in rec["/tf/laser"])

    # Plots, events, timeline kind (wall stamps -> timestamp).
    assert values(rec["/plots/loop_time/move_base"], "Scalars:scalars")
    assert values(rec["/plots/cmd_vel/linear_x"], "Scalars:scalars")
    texts = [t[0] for t in values(rec["/log/move_base"], "TextLog:text")]
    assert any(t.startswith("PLANNING") for t in texts)
    assert any(t.startswith("CONTROLLING") for t in texts)
    # One event per state change: not one per status message, and "blocked for 0.3 s" -> "0.4 s" is no change.
    assert len(texts) < len(published["move_base/status"]) / 3
    assert not any(a.split()[0] == b.split()[0] for a, b in zip(texts, texts[1:]))
    assert "move_base: RUNNING" in [t[0] for t in values(rec["/log/agent/synth"], "TextLog:text")]
    sensors = [t[0] for t in values(rec["/log/local_costmap/sensors"], "TextLog:text")]
    assert sensors == ["local_costmap: 1 source(s) ok ('laser_scan_sensor' on 'scan')"]  # once: no change
    assert values(rec["/plots/sensors/local_costmap/obstacle_layer/laser_scan_sensor"], "Scalars:scalars")
    assert rec["/world/scan"][0]["_stamp_type"].startswith("timestamp")

    # Where the scan lands: its points (odom frame) through the recorded map<-odom edge at the scan's stamp
    # fall on occupied cells of the recorded map.
    map_odom = {r["stamp"]: r for r in rec["/tf/odom"] if r.get("Transform3D:translation")}
    scan_row = next(r for r in reversed(rec["/world/scan"])
                    if r["stamp"] in map_odom and r.get("CoordinateFrame:frame") == ["odom"])
    pts = _tf(map_odom[scan_row["stamp"]]).apply(np.array(scan_row["Points3D:positions"], dtype=float))
    grid_row = rec["/world/map"][-1]
    fmt = grid_row["GridMap:format"][0]
    occ = np.array(grid_row["GridMap:data"][0], np.uint8).reshape(fmt["height"], fmt["width"])[::-1]  # top row first
    col = np.floor((pts[:, 0] - map_origin.x) / syn.RES).astype(int)
    row = np.floor((pts[:, 1] - map_origin.y) / syn.RES).astype(int)
    near = [(occ[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2] == 100).any() for r, c in zip(row, col)]
    assert np.mean(near) > 0.98, f"only {np.mean(near):.0%} of the scan points land on walls"


def test_sigterm_closes_the_recording(tmp_path, robot_bus):
    robot, ep, _ = robot_bus
    out, proc = _monitor(tmp_path, robot, ep)
    try:
        # Data is flowing once the file has grown past the header and the first chunks.
        wait_for(lambda: out.exists() and out.stat().st_size > 200_000 or proc.poll() is not None,
                 timeout=60, what="the recording to grow")
        assert proc.poll() is None, proc.communicate()[1]
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert "received=" in err
    assert has_footer(out)
    assert "/world/map" in read_rrd(out)
