"""The hector node on a private loopback bus: scans of a synthetic room in, map and TF out; the
odometry TF is wrong on purpose and map->odom absorbs it (the matcher never reads it)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid, TransformStamped
from tests.slam.conftest import _room_scan
from tests.support import free_port, wait_until


def test_node_publishes_map_and_map_to_odom_that_puts_the_base_at_its_true_pose(robot_name):
    from common.bus import Node
    from common.tf import StaticTFBroadcaster, TFBroadcaster, TFListener
    from common.zenoh_config import BusConfig
    from master_side.hector.node import start

    node = Node("hector_test", config=BusConfig(robot=robot_name, multicast=False,
                                                listen=(f"tcp/127.0.0.1:{free_port()}",)), use_sim_time=False)
    cfg = {"map_frame": "map", "map_resolution": 0.05, "map_size": 512, "laser_min_dist": 0.05,
           "laser_max_dist": 20.0, "map_pub_period": 0.0, "map_update_distance_thresh": 0.2}
    hector = start(node, cfg, "test.yaml")
    try:
        tf_out, static = TFBroadcaster(node), StaticTFBroadcaster(node)
        static.send(TransformStamped(Header(0.0, "base_link"), "laser", Pose2D().to_transform()))
        listener = TFListener(node)
        maps = node.subscribe("map", OccupancyGrid)
        scan_pub = node.publisher("scan")
        odom_origin = Pose2D(5.0, -3.0, 1.0)  # odometry's frame is far from the map's: any offset works
        truth = Pose2D()
        for k in range(25):
            truth = Pose2D(-1.0 + 0.06 * k, -0.5 + 0.02 * k, 0.02 * k)
            t = node.clock.now()
            tf_out.send(TransformStamped(Header(t, "odom"), "base_link",
                                         odom_origin.compose(truth).to_transform()))
            wait_until(lambda t=t: listener.buffer.can_transform("odom", "base_link", t), 5.0, "odom TF")
            scan = _room_scan(truth)
            handled = hector.handled
            scan_pub.publish(replace(scan, header=Header(t, "laser")))
            wait_until(lambda h=handled: hector.handled > h, 10.0, "the scan to be processed")
        assert hector.no_tf == 0
        # map frame = the first scan's base pose: map->base_link must be the motion since then
        first = Pose2D(-1.0, -0.5, 0.0)
        expected = first.between(truth)
        est = listener.buffer.lookup("map", "base_link", t, timeout=2.0).transform.to_pose2d()
        assert np.hypot(est.x - expected.x, est.y - expected.y) < 0.05 and abs(est.theta - expected.theta) < 0.02
        grid = wait_until(maps.latest, 5.0, "a map")
        assert grid.header.frame_id == "map" and int((grid.data == 100).sum()) > 200
    finally:
        hector.close()
        node.close()
