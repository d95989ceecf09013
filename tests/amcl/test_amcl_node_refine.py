"""The amcl node with refine_pose on a private loopback bus: map, scans and odometry TF in; amcl_pose at every
scan (the refined pose), the particle cloud only at filter updates, and map->odom that puts the base at its
true pose while the odometry drifts."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, LaserScan, Path, PoseStamped, TransformStamped
from tests.amcl.amcl_support import LASER, box_map, cast, cast_scan, solid_world
from tests.support import free_port, wait_until

LASER_IN_BASE = Pose2D(0.1, 0.0, 0.0)


def test_node_publishes_the_refined_pose_at_every_scan_and_the_cloud_at_filter_updates(robot_name):
    from common.bus import Node
    from common.tf import StaticTFBroadcaster, TFBroadcaster, TFListener
    from common.zenoh_config import BusConfig
    from master_side.localization.amcl_node import start

    node = Node("amcl_refine_test", config=BusConfig(robot=robot_name, multicast=False,
                                                     listen=(f"tcp/127.0.0.1:{free_port()}",)), use_sim_time=False)
    truth = Pose2D(-3.0, 2.0, 0.0)
    cfg = {"refine_pose": True, "laser_model_type": "likelihood_field_prob", "laser_sigma_hit": 0.05,
           "initial_pose_x": truth.x, "initial_pose_y": truth.y, "initial_pose_a": truth.theta,
           "initial_cov_xx": 0.0025, "initial_cov_yy": 0.0025, "initial_cov_aa": 0.001, "seed": 3,
           "update_min_d": 0.2, "transform_publish_period": 0.02}
    amcl = start(node, cfg, "test.yaml")
    try:
        grid = box_map()
        solid = solid_world(grid)
        tf_out, static = TFBroadcaster(node), StaticTFBroadcaster(node)
        static.send(TransformStamped(Header(0.0, "base_link"), "laser", LASER_IN_BASE.to_transform()))
        listener = TFListener(node)
        poses: list[PoseStamped] = []
        clouds: list[Path] = []
        node.subscribe("amcl_pose", PoseStamped, callback=poses.append, mode="queue")
        node.subscribe("particlecloud", Path, callback=clouds.append, mode="queue")
        node.publisher("map", latched=True).publish(grid)
        wait_until(lambda: amcl.filter is not None, 10.0, "the map to reach amcl")
        scan_pub = node.publisher("scan")
        template = cast_scan(grid, truth, **LASER)
        odom = Pose2D()
        for k in range(30):  # 3 m along y = 2 in 0.1 m steps; odometry turns 0.05 rad per metre too many
            step = Pose2D(0.1, 0.0, 0.0)
            truth = truth.compose(step)
            odom = odom.compose(step).compose(Pose2D(0.0, 0.0, 0.005))
            t = node.clock.now()
            tf_out.send(TransformStamped(Header(t, "odom"), "base_link", odom.to_transform()))
            wait_until(lambda t=t: listener.buffer.can_transform("odom", "base_link", t), 5.0, "odom TF")
            scan: LaserScan = replace(template, header=Header(t, "laser"),
                                      ranges=cast(grid, solid, truth.compose(LASER_IN_BASE), step=0.0025)
                                      .astype(np.float32))
            scan_pub.publish(scan)
            wait_until(lambda t=t: any(p.header.stamp == t for p in poses[-3:]), 10.0, f"amcl_pose for scan {k}")
        est = amcl.filter.map_to_odom().compose(odom)
        assert math.hypot(est.x - truth.x, est.y - truth.y) < 0.01, (est, truth)
        assert abs(math.remainder(est.theta - truth.theta, 2 * math.pi)) < 0.005
        tf_est = listener.buffer.lookup("map", "base_link", t, timeout=2.0).transform.to_pose2d()
        assert math.hypot(tf_est.x - truth.x, tf_est.y - truth.y) < 0.01, (tf_est, truth)
        assert len(poses) == 30  # one pose per scan
        # the cloud at filter updates only: the first scan, then every 0.2 m (odometry's x or y)
        assert 10 <= len(clouds) <= 20, len(clouds)
    finally:
        amcl.close()
        node.close()
