"""zenav's event-driven mode, end to end over the bus on a simulated clock that the test holds still:
with ``update_on_observation`` the local costmap includes a scan in an update at once, and with
``control_on_costmap`` move_base runs a control cycle as soon as a local costmap arrives. With the
fixed-rate loops of ROS (the default) neither happens before the clock reaches the next tick."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from bushelp import wait_for

from common.geometry import Pose2D, Transform
from common.messages import (
    Clock,
    Costmap,
    Header,
    LaserScan,
    MoveBaseGoal,
    PoseStamped,
    Scalar,
    TransformStamped,
)
from common.tf import StaticTFBroadcaster, TFBroadcaster

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def _traces(node, topic: str) -> list:
    got: list = []
    node.subscribe(topic, Scalar, callback=got.append, mode="queue", queue_size=10000)
    return got


def _set_clock(tester, clock_pub, tf, t: float, edges) -> None:
    clock_pub.publish(Clock(t))
    tf.send([TransformStamped(Header(t, p), c, Transform()) for p, c in edges])


def test_the_local_costmap_updates_when_a_scan_arrives(node_pair, tmp_path):
    from master_side.costmap.node import start

    tester, cm_node = node_pair("tester", use_sim_time=False), node_pair("local_costmap", use_sim_time=True)
    clock_pub, tf = tester.publisher("clock", reliable=True), TFBroadcaster(tester)
    traces = _traces(tester, "local_costmap/costmap_trace")
    StaticTFBroadcaster(tester).send(TransformStamped(Header(0.0, "base_link"), "camera_link", Transform()))
    spec = yaml.safe_load((CONFIG / "local_costmap_padded.yaml").read_text())
    spec["local_costmap"].update(update_frequency=1.0, update_on_observation=True)
    (tmp_path / "local.yaml").write_text(yaml.safe_dump(spec))
    cfg = {"name": "local_costmap", "common": str(CONFIG / "p3at/costmap_common_params.yaml"),
           "specific": str(tmp_path / "local.yaml")}
    costmap = start(cm_node, cfg, str(CONFIG / "p3at_known_map.yaml"))
    scan_pub = tester.publisher("scan", reliable=True)
    try:
        wait_for(lambda: clock_pub._pub.matching_status.matching and scan_pub._pub.matching_status.matching,
                 30, "the costmap's subscriptions")
        _set_clock(tester, clock_pub, tf, 100.0, [("odom", "base_link")])
        wait_for(lambda: traces, 30, "the first (idle) update")  # due at clock 2 s: runs once the clock jumps
        # 1.5 s later (past the 1 s period, before the idle run at 102 s); the clock then stays there
        _set_clock(tester, clock_pub, tf, 101.5, [("odom", "base_link")])
        wait_for(lambda: cm_node.clock.now() == 101.5, 30, "the costmap's clock at 101.5 s")
        ranges = np.full(360, 1.0, np.float32)
        scan_pub.publish(LaserScan(Header(101.5, "camera_link"), -1.0, 1.0, 2.0 / 359, 0.0, 0.1, 0.45, 10.0,
                                   ranges, np.zeros(0, np.float32)))
        got = wait_for(lambda: next((t for t in traces if t.value == 101.5), None), 30,
                       "an update including the scan while the clock stands still")
        assert got.header.stamp == 101.5
        assert costmap.timers[0].kicks >= 1
    finally:
        costmap.close()


def test_move_base_runs_a_cycle_when_a_local_costmap_arrives(node_pair, tmp_path):
    from master_side.move_base.node import start

    source = CONFIG / "p3at_known_map.yaml"
    params = yaml.safe_load(source.read_text())["nodes"]["move_base"]["params"]
    mb_file = tmp_path / "move_base.yaml"
    mb_yaml = yaml.safe_load((CONFIG / params["move_base"]).read_text())
    mb_file.write_text(yaml.safe_dump({**mb_yaml, "controller_frequency": 1.0, "control_on_costmap": True}))
    params = {**params, "move_base": str(mb_file)}
    tester, mb_node = node_pair("tester", use_sim_time=False), node_pair("move_base", use_sim_time=True)
    clock_pub, tf = tester.publisher("clock", reliable=True), TFBroadcaster(tester)
    traces = _traces(tester, "move_base/cmd_trace")
    local = tester.publisher("local_costmap/costmap", reliable=True)
    edges = [("map", "odom"), ("odom", "base_link")]
    mb = start(mb_node, params, str(source))
    try:
        goal = tester.publisher("move_base/goal", reliable=True)
        wait_for(lambda: all(p._pub.matching_status.matching for p in (goal, local, clock_pub)), 30,
                 "move_base's subscriptions")
        _set_clock(tester, clock_pub, tf, 100.0, edges)
        wait_for(lambda: mb_node.clock.now() == 100.0, 30, "move_base's clock at 100 s")
        goal.publish(MoveBaseGoal("g1", PoseStamped(Header(100.0, "map"), Pose2D(1.0, 0.0, 0.0).to_transform())))
        wait_for(lambda: mb.machine.goal is not None, 30, "the goal accepted")
        grid = np.zeros((120, 120), np.uint8)
        # The clock's jump to 100 s ran the idle cycle (due at 2 s). 101.5 s: past the 1 s period, before the
        # next idle cycle at 102 s; 103 s: 1.5 s after the cycle of 101.5 s, before its idle one at 103.5 s.
        for t in (101.5, 103.0):
            _set_clock(tester, clock_pub, tf, t, edges)
            wait_for(lambda t=t: mb_node.clock.now() == t, 30, f"move_base's clock at {t} s")
            local.publish(Costmap(Header(t, "odom"), 0.025, Pose2D(-1.5, -1.5, 0.0), grid))
            wait_for(lambda t=t: any(m.value == t for m in traces), 30,
                     f"a control cycle using the costmap of {t} s while the clock stands still")
        assert mb.timer.kicks >= 2
    finally:
        mb.close()
