"""A costmap with a static layer publishes nothing until its map has come (ROS's StaticLayer holds the
costmap's start until then): move_base must never plan on a grid of the default size without the map
(the demo once aborted its first goal with "start (-2.20, 0.00) is off the costmap")."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from bushelp import wait_for

from common.geometry import Pose2D
from common.messages import Costmap, Header, OccupancyGrid, Text

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def test_the_global_costmap_waits_for_its_map_then_takes_its_geometry(node_pair, tf_feed):
    from master_side.costmap.node import start

    tester, cm_node = node_pair("tester", use_sim_time=False), node_pair("global_costmap", use_sim_time=False)
    grids = tester.subscribe("global_costmap/costmap", Costmap, mode="queue", queue_size=1000)
    said: list[str] = []
    tester.subscribe("global_costmap/status", Text, callback=lambda m: said.append(m.data), mode="queue")
    tf_feed(tester, [("map", "base_link")])
    cfg = {"name": "global_costmap", "common": "p3at/costmap_common_params.yaml",
           "specific": "global_costmap_known_map.yaml"}
    costmap = start(cm_node, cfg, str(CONFIG / "p3at_known_map.yaml"))
    try:
        wait_for(lambda: any("waiting for the map on map" in t for t in said), 30, "the 'waiting for the map' status")
        # the costmap updates at 1 Hz: two cycles on, still nothing published
        n = len(said)
        wait_for(lambda: len(said) >= n + 2, 30, "two more update cycles")
        assert grids.received == 0, "a costmap went out before its static map came"
        data = np.zeros((60, 80), np.int8)
        data[30, 40] = 100
        tester.publisher("map", latched=True).publish(
            OccupancyGrid(Header(time.time(), "map"), 0.05, Pose2D(-2.5, -1.0, 0.0), data))
        first = grids.wait_first(30.0)
        assert first.data.shape == (60, 80)
        assert (first.origin.x, first.origin.y) == (-2.5, -1.0)
        assert first.data[30, 40] == 254  # the map's obstacle, lethal
    finally:
        costmap.close()
