"""A rolling local costmap with a static layer places the map by the *current* map -> odom transform on
every update, as ROS's StaticLayer does: when localisation corrects the odometry's drift, the walls in the
local costmap move with it (they used to stay where the first map message put them). A map that comes
before map -> odom exists (AMCL publishes it after its first update) is kept and placed once it does."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import yaml
from bushelp import wait_for

from common.geometry import Pose2D, Transform
from common.messages import Costmap, Header, OccupancyGrid, Text, TransformStamped
from common.tf import TFBroadcaster

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def _wall_x(grid: Costmap) -> float:
    """x (odom) of the lethal column in the costmap."""
    cols = np.flatnonzero((grid.data == 254).any(axis=0))
    return grid.origin.x + (cols.mean() + 0.5) * grid.resolution


def test_the_walls_of_a_rolling_static_layer_move_with_map_to_odom(node_pair, tmp_path):
    from master_side.costmap.node import start

    spec = yaml.safe_load((CONFIG / "local_costmap_padded.yaml").read_text())
    spec["local_costmap"].update(static_map=True, update_frequency=10.0)
    (tmp_path / "local.yaml").write_text(yaml.safe_dump(spec))
    tester, cm_node = node_pair("tester", use_sim_time=False), node_pair("local_costmap", use_sim_time=False)
    grids = tester.subscribe("local_costmap/costmap", Costmap, mode="latest")
    offset = [0.0]  # map -> odom, x (m)
    stop = threading.Event()
    tf = TFBroadcaster(tester)

    def feed() -> None:
        while not stop.is_set():
            now = time.time()
            tf.send([TransformStamped(Header(now, "map"), "odom", Pose2D(offset[0], 0.0, 0.0).to_transform()),
                     TransformStamped(Header(now, "odom"), "base_link", Transform())])
            stop.wait(0.05)

    said: list[str] = []
    tester.subscribe("local_costmap/status", Text, callback=lambda m: said.append(m.data), mode="queue")
    feeder = threading.Thread(target=feed, daemon=True)
    data = np.zeros((100, 100), np.int8)
    data[:, 60] = 100  # a wall along y at x = 0.5 m in the map frame (0.05 m cells from -2.5)
    tester.publisher("map", latched=True).publish(
        OccupancyGrid(Header(time.time(), "map"), 0.05, Pose2D(-2.5, -2.5, 0.0), data))
    costmap = start(cm_node, {"name": "local_costmap", "common": str(CONFIG / "p3at/costmap_common_params.yaml"),
                              "specific": str(tmp_path / "local.yaml")}, str(tmp_path / "master.yaml"))
    try:
        wait_for(lambda: any("not updating" in t for t in said), 30, "a costmap without transforms saying so")
        feeder.start()  # the map came first; now the transforms
        wait_for(lambda: grids.latest() is not None and (grids.latest().data == 254).any(), 30, "the wall")
        assert abs(_wall_x(grids.latest()) - 0.525) < 0.03
        offset[0] = -0.3  # localisation moved odom 0.3 m back in the map: the wall is 0.3 m further ahead in odom
        wait_for(lambda: abs(_wall_x(grids.latest()) - 0.825) < 0.03, 30, "the wall 0.3 m further in odom")
    finally:
        stop.set()
        if feeder.is_alive():
            feeder.join(2.0)
        costmap.close()
