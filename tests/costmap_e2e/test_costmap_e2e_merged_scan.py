"""Issue 4 acceptance: end to end in the simulator, the robot agent with the virtualizer config
(robot_side/config/p3at_sim_virtual.yaml: Kinect -> cloud -> 8 virtual scans -> merger) publishes one
merged ``scan`` at the camera rate, from one publisher, and it sees the room's crate and walls where they are.
"""

from __future__ import annotations

import numpy as np
import pytest

from common.bus import list_live
from common.geometry import Pose2D
from common.messages import CameraInfo, LaserScan, Odometry
from master_side.costmap.observation import scan_to_points
from robot_side.sim.depth_camera import DepthCameraParams
from tests.costmap_e2e.costmap_e2e_rig import CmeRecorder, RoomTruth, cme_wait, robot_agent_argv

START = (-1.0, 0.1, -0.1)  # crate face 0.7 m ahead, the far wall ~4 m behind it
FRAMES = 45  # camera frames in the measured window (3 s at the Kinect's 15 Hz)


def stamps(msgs) -> np.ndarray:
    return np.array([m.header.stamp for m in msgs])


@pytest.mark.slow
def test_virtualizer_config_publishes_one_merged_scan_per_camera_frame(cme_bus, cme_procs, robot_name):
    node, env = cme_bus
    room = RoomTruth.load()
    info = CmeRecorder(node, "camera/depth/camera_info", CameraInfo)
    scan = CmeRecorder(node, "scan", LaserScan)
    truth = CmeRecorder(node, "ground_truth", Odometry, queue_size=50)
    plane0 = CmeRecorder(node, "virtual_scans/0", LaserScan)
    agent = cme_procs("robot_agent", robot_agent_argv("robot_side/config/p3at_sim_virtual.yaml", robot_name,
                                                      "--world", "room", "--start", *map(str, START)), env)
    cme_wait(lambda: len(scan) >= 5, 120, "merged scans", (agent,))
    # measure from the first camera frame after the pipeline is flowing
    t0 = info.msgs()[-1].header.stamp
    cme_wait(lambda: sum(m.header.stamp > t0 for m in info.msgs()) >= FRAMES + 1, 60,
             f"{FRAMES} camera frames", (agent,))
    cam = stamps(info.msgs())
    cam = cam[cam > t0][: FRAMES + 1]
    t1 = cam[-1]
    # the merged scan of the window's last frame may still be on its way
    cme_wait(lambda: stamps(scan.msgs()).max() >= t1, 10, "the merged scan of the last frame", (agent,))
    merged = stamps(scan.msgs())
    merged = merged[(merged > t0) & (merged <= t1)]
    virtual = stamps(plane0.msgs())
    virtual = virtual[(virtual > t0) & (virtual <= t1)]

    cam_hz = (len(cam) - 1) / (t1 - cam[0])
    in_window = merged[merged >= cam[0]]
    scan_hz = (len(in_window) - 1) / (in_window[-1] - in_window[0]) if len(in_window) > 1 else 0.0
    print(f"\ncostmap_e2e: camera {cam_hz:.2f} Hz, merged scan {scan_hz:.2f} Hz (sim time); "
          f"{len(merged)} merged scans, {len(virtual)} virtual_scans/0 for {len(cam)} camera frames")
    # one merged scan per camera frame, stamped with that frame's stamp: not one per virtual plane
    assert len(np.unique(merged)) == len(merged), "several merged scans for one camera frame"
    assert np.abs(merged[:, None] - cam[None, :]).min(axis=1).max() < 1e-4, "merged stamps not frame stamps"
    # stream topics use the drop congestion policy (README, Reliability): on a loaded machine a depth image
    # or one of a set's eight virtual scans may be lost on the way, and that set gives no merged scan. Idle,
    # every frame gives one (45/45); a loaded CI run (2026-11-27) gave 36 for 46 frames. So this asserts a
    # merged scan for most frames (a merger waiting for two frames' sets, or publishing every other one,
    # fails), and the pipeline's speed is measured where the load is known: `python bench/depth.py`
    # (8 virtual scans + merge ~10 ms per 66 ms frame). Against the sets seen on virtual_scans/0 the bound is
    # 3/4: the two faults this guards against give at most half (one merge per two sets), while a set loses
    # its merge when any of its eight scans, or the merged scan itself, is dropped on its own route (41 for
    # 46 in a loaded rehearsal, 2026-11-30, under the 9/10 this bound had).
    assert len(merged) >= 0.6 * len(cam), f"{len(merged)} merged scans for {len(cam)} camera frames"
    assert len(merged) >= 0.75 * len(virtual), f"{len(merged)} merged scans for {len(virtual)} virtual scan sets"
    assert scan_hz <= 1.05 * cam_hz

    # exactly one publisher of scan: the merger
    pubs = [k for k in list_live(node.session, robot_name, "pub", timeout=2.0) if k.endswith("/scan")]
    assert pubs == [f"{robot_name}/pub/merger/scan"], pubs
    assert scan.sub.last_publisher == "merger"

    # the merged scan sees the crate's face and the far wall where they are (base_link -> map by ground truth)
    last = scan.msgs()[-1]
    assert last.header.frame_id == "base_link"
    pose = min(truth.msgs(), key=lambda m: abs(m.header.stamp - last.header.stamp)).pose2d
    assert pose.distance(Pose2D(*START)) < 1e-6
    pts = pose.apply(scan_to_points(last)[:, :2])
    assert len(pts) > 100
    d = room.surface_distance(pts)
    rng = np.hypot(pts[:, 0] - pose.x, pts[:, 1] - pose.y)
    # the simulated Kinect's depth noise has std noise_z2 * depth^2 (2.6 cm at 4.2 m) and each merged ray
    # keeps the nearest of many noisy returns (8 planes), so far returns come out short by a few sigma;
    # 1 cm covers the world's 2 cm raster and the binning (noise-free, the error is < 8 mm everywhere)
    tol = 0.01 + 4 * DepthCameraParams().noise_z2 * rng ** 2
    print(f"costmap_e2e: {len(pts)} merged returns: distance to the nearest true surface "
          f"mean {d.mean():.4f} m, max {d.max():.4f} m; within 1 m: max {d[rng < 1].max():.4f} m")
    assert (d <= tol).all(), f"returns off every surface: {np.column_stack((pts, rng, d))[d > tol][:5]}"
    on_crate = room.crate_distance(pts) < 0.03
    on_wall = room.wall_distance(pts) < 0.05
    assert on_crate.sum() >= 20, on_crate.sum()
    assert on_wall.sum() >= 20, on_wall.sum()
    face = pts[on_crate]
    assert np.abs(face[:, 0] - room.crate_min[0]).mean() < 0.01
    assert face[:, 1].min() < room.crate_min[1] + 0.05
    assert face[:, 1].max() > room.crate_max[1] - 0.05
