"""Issue 5 acceptance: fed by the simulated robot over Zenoh (separate processes), the local costmap
shows the room's obstacle at its true position (within one cell).

Processes: the robot agent with the tutorial's Kinect config (sim -> depth image -> depth_to_scan ->
``scan`` in camera_depth_frame, base_link -> camera_link from the tutorial's static transform) and the
costmap node with the tutorial's flat costmap_common_params.yaml + local_costmap_params.yaml (rolling
3 m x 3 m at 0.025 m in odom). The robot starts 0.7 m behind the crate's near face, facing it, off the
crate's axis and slightly turned, so a mirrored scan or a frame rotation error cannot look right.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import yaml

from common.geometry import Pose2D
from common.messages import Costmap, LaserScan, Odometry
from common.tf import TFListener
from master_side.costmap.cost_values import LETHAL
from master_side.costmap.observation import scan_to_points
from tests.costmap_e2e.costmap_e2e_rig import (
    REPO,
    CmeRecorder,
    RoomTruth,
    cme_wait,
    map_from_odom,
    robot_agent_argv,
)

START = (-1.0, 0.1, -0.1)  # robot start in map: crate face 0.7 m ahead, the whole face in the Kinect's view
P3AT = REPO / "master_side" / "config" / "p3at"
STEADY_GRIDS = 5  # consecutive obstacle-layer grids that must all pass


def lethal_cells_in_map(grid: Costmap, map_odom) -> np.ndarray:
    """Centres (N, 2) of the LETHAL cells of a grid in odom, moved into map."""
    my, mx = np.nonzero(grid.data == LETHAL)
    o, r = grid.origin, grid.resolution
    assert abs(o.theta) < 1e-12
    cx, cy = o.x + (mx + 0.5) * r, o.y + (my + 0.5) * r
    p = map_odom.apply(np.column_stack((cx, cy))) if len(cx) else np.zeros((0, 2))
    return np.asarray(p, float).reshape(-1, 2)


def face_stats(cells: np.ndarray, room: RoomTruth, res: float) -> dict:
    """The marked cells of the crate's visible face (x = crate min x, |y| <= half width) and how many
    distinct cell rows of the face they cover."""
    face_x = room.crate_min[0]
    y0, y1 = room.crate_min[1], room.crate_max[1]
    on = np.abs(cells[:, 1] - room.crate_center[1]) <= (y1 - y0) / 2
    on &= np.abs(cells[:, 0] - face_x) <= 3 * res
    face = cells[on]
    rows = np.unique(np.floor((face[:, 1] - y0) / res).astype(int)) if len(face) else np.zeros(0, int)
    want = int(round((y1 - y0) / res))
    return {"face": face, "offsets": np.abs(face[:, 0] - face_x), "rows": len(rows), "rows_wanted": want}


@pytest.mark.slow
def test_local_costmap_marks_the_crate_face_within_one_cell(cme_bus, cme_procs, tmp_path, robot_name):
    node, env = cme_bus
    room = RoomTruth.load()
    truth = CmeRecorder(node, "ground_truth", Odometry, queue_size=200)
    odom = CmeRecorder(node, "odom", Odometry, queue_size=200)
    layer = CmeRecorder(node, "local_costmap/costmap/obstacle_layer", Costmap, queue_size=50)
    master = CmeRecorder(node, "local_costmap/costmap", Costmap, queue_size=50)
    scans = CmeRecorder(node, "scan", LaserScan, queue_size=50)
    tf = TFListener(node)

    robot = cme_procs("robot_agent", robot_agent_argv("robot_side/config/p3at_sim.yaml", robot_name,
                                                      "--world", "room", "--start", *map(str, START)), env)
    cfg = tmp_path / "local_costmap.yaml"
    cfg.write_text(yaml.safe_dump({"local_costmap": {
        "name": "local_costmap", "common": str(P3AT / "costmap_common_params.yaml"),
        "specific": str(P3AT / "local_costmap_params.yaml")}}))
    costmap = cme_procs("local_costmap", [sys.executable, "-m", "master_side.costmap.node", "--config",
                                          str(cfg), "--section", "local_costmap", "--name", "local_costmap"],
                        {**env, "ZENAV_USE_SIM_TIME": "1"})
    procs = (robot, costmap)

    map_odom = cme_wait(lambda: map_from_odom(truth.msgs(), odom.msgs()), 90, "ground_truth + odom", procs)
    res = 0.025
    # odom starts at the start pose and the robot stands still: map <- odom is the start pose
    assert map_odom.distance(Pose2D(*START)) < 1e-6
    assert abs(map_odom.theta - START[2]) < 1e-6

    def face_seen() -> bool:
        grids = layer.msgs()
        if not grids:
            return False
        st = face_stats(lethal_cells_in_map(grids[-1], map_odom), room, grids[-1].resolution)
        return st["rows"] >= 0.9 * st["rows_wanted"]

    cme_wait(face_seen, 90, "the crate's face in local_costmap/costmap/obstacle_layer", procs)
    n0 = len(layer)
    cme_wait(lambda: len(layer) >= n0 + STEADY_GRIDS, 30, f"{STEADY_GRIDS} more obstacle-layer grids", procs)
    grids = layer.msgs()[n0:n0 + STEADY_GRIDS]
    # the robot stood still: map <- odom is the same for every grid
    assert map_from_odom(truth.msgs(), odom.msgs()).distance(map_odom) < 1e-9

    all_offsets = []
    for g in grids:
        assert g.header.frame_id == "odom"
        assert g.resolution == pytest.approx(res)
        assert g.data.shape == (120, 120)
        cells = lethal_cells_in_map(g, map_odom)
        st = face_stats(cells, room, g.resolution)
        # the crate's visible face: marked over its whole width, every marked cell within one cell of it
        assert st["rows"] >= 0.9 * st["rows_wanted"], (st["rows"], st["rows_wanted"])
        assert st["offsets"].max() <= res + 1e-9, f"face cells up to {st['offsets'].max():.4f} m off"
        all_offsets.append(st["offsets"])
        # nothing LETHAL in free space: every marked cell is within one cell of the crate or a wall
        d = room.surface_distance(cells)
        bad = cells[d > res + 1e-9]
        assert len(bad) == 0, f"{len(bad)} LETHAL cells away from every obstacle, e.g. {bad[:5].tolist()}"
    off = np.concatenate(all_offsets)
    print(f"\ncostmap_e2e: start {START}; crate face x={room.crate_min[0]:.3f} m; {len(off)} face cells over "
          f"{len(grids)} grids: mean |dx| {off.mean():.4f} m, max {off.max():.4f} m (cell {res} m)")

    # sub-cell check of the sensor chain (Kinect -> depth_to_scan -> TF camera_depth_frame -> odom -> map):
    # the scan's returns on the face lie on it
    scan = scans.msgs()[-1]
    to_odom = tf.buffer.lookup("odom", scan.header.frame_id, scan.header.stamp, timeout=10.0).transform
    tf.close()
    pts = scan_to_points(scan)
    pts = map_odom.apply(to_odom.apply(pts)[:, :2])
    face = (np.abs(pts[:, 1]) < room.crate_max[1] - 0.02) & (np.abs(pts[:, 0] - room.crate_min[0]) < 0.1)
    assert face.sum() >= 20, f"only {face.sum()} scan returns on the crate face"
    dx = pts[face, 0] - room.crate_min[0]
    print(f"costmap_e2e: {face.sum()} scan returns on the face: mean dx {dx.mean():+.4f} m, "
          f"max |dx| {np.abs(dx).max():.4f} m")
    assert abs(dx.mean()) < 0.005
    assert np.abs(dx).max() < 0.02
    ys = pts[face, 1]
    assert ys.min() < room.crate_min[1] + 0.05, "face not seen whole"
    assert ys.max() > room.crate_max[1] - 0.05, "face not seen whole"

    # the master grid carries the same LETHAL cells (inflation adds only lower costs around them)
    by_stamp = {m.header.stamp: m for m in master.msgs()}
    pairs = [(g, by_stamp[g.header.stamp]) for g in grids if g.header.stamp in by_stamp]
    assert pairs, "no master grid published with an obstacle-layer grid"
    for g, m in pairs:
        assert np.array_equal(m.data == LETHAL, g.data == LETHAL)
