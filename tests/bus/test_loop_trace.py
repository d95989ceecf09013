"""Traceability for bench/loop.py: the local costmap says which observation it includes
(``<name>/costmap_trace``) and move_base which costmap each cmd_vel came from (``move_base/cmd_trace``)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import yaml
from bushelp import wait_for

from common.geometry import Pose2D, Transform
from common.messages import Costmap, Header, LaserScan, MoveBaseGoal, PoseStamped, Scalar, TransformStamped
from common.tf import StaticTFBroadcaster

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def _traces(node, topic: str) -> list:
    got: list = []
    node.subscribe(topic, Scalar, callback=got.append, mode="queue", queue_size=10000)
    return got


def test_the_local_costmap_traces_the_newest_scan_it_includes(node_pair, tf_feed):
    from master_side.costmap.node import start

    tester, cm_node = node_pair("tester", use_sim_time=False), node_pair("local_costmap", use_sim_time=False)
    traces = _traces(tester, "local_costmap/costmap_trace")
    StaticTFBroadcaster(tester).send(TransformStamped(Header(0.0, "base_link"), "camera_link", Transform()))
    tf_feed(tester, [("odom", "base_link")])
    cfg = {"name": "local_costmap", "common": "p3at/costmap_common_params.yaml",
           "specific": "local_costmap_padded.yaml"}
    costmap = start(cm_node, cfg, str(CONFIG / "p3at_known_map.yaml"))
    scan_pub = tester.publisher("scan", reliable=True)
    try:
        wait_for(lambda: traces, 30, "a costmap_trace")
        assert all(t.value == 0.0 for t in traces)  # nothing observed yet
        stamps = []
        for _ in range(3):
            time.sleep(0.3)
            stamps.append(time.time() - 0.1)  # inside the TF cache, before the latest transform
            ranges = np.full(360, 1.0, np.float32)
            scan_pub.publish(LaserScan(Header(stamps[-1], "camera_link"), -1.0, 1.0, 2.0 / 359, 0.0, 0.1, 0.45,
                                       10.0, ranges, np.zeros(0, np.float32)))
            wait_for(lambda s=stamps[-1]: any(t.value == s for t in traces), 30, "the scan's stamp in a trace")
        values = [t.value for t in traces]
        assert values == sorted(values)  # the newest included, never going back
        assert set(values) <= {0.0, *stamps}
        first = next(t for t in traces if t.value == stamps[0])
        assert first.header.stamp >= stamps[0]  # the costmap was updated after the scan was taken
    finally:
        costmap.close()


def test_move_base_traces_the_local_costmap_each_cmd_vel_came_from(node_pair, tf_feed):
    from master_side.move_base.node import start

    source = CONFIG / "p3at_known_map.yaml"
    params = yaml.safe_load(source.read_text())["nodes"]["move_base"]["params"]
    tester, mb_node = node_pair("tester", use_sim_time=False), node_pair("move_base", use_sim_time=False)
    traces = _traces(tester, "move_base/cmd_trace")
    cmd = tester.subscribe("cmd_vel")
    tf_feed(tester, [("map", "odom"), ("odom", "base_link")])
    local = tester.publisher("local_costmap/costmap", reliable=True)
    mb = start(mb_node, params, str(source))
    try:
        goal = tester.publisher("move_base/goal", reliable=True)
        wait_for(lambda: goal._pub.matching_status.matching and local._pub.matching_status.matching, 30,
                 "move_base's subscriptions")
        grid = np.zeros((120, 120), np.uint8)
        first, second = 1000.25, 2000.5  # stamps no clock would give: only the trace can carry them
        local.publish(Costmap(Header(first, "odom"), 0.025, Pose2D(-1.5, -1.5, 0.0), grid))
        time.sleep(0.3)
        goal.publish(MoveBaseGoal("g1", PoseStamped(Header(time.time(), "map"), Pose2D(1.0, 0.0, 0.0).to_transform())))
        wait_for(lambda: any(t.value == first for t in traces), 30, "a cmd_trace naming the first costmap")
        # cmd_vel goes out just before its trace, on its own route: wait for it rather than race it
        wait_for(lambda: cmd.received > 0, 30, "a cmd_vel")
        local.publish(Costmap(Header(second, "odom"), 0.025, Pose2D(-1.5, -1.5, 0.0), grid))
        wait_for(lambda: any(t.value == second for t in traces), 30, "a cmd_trace naming the second costmap")
        values = [t.value for t in traces]
        assert set(values) <= {first, second}
        assert values.index(second) > max(i for i, v in enumerate(values) if v == first)
    finally:
        mb.close()
