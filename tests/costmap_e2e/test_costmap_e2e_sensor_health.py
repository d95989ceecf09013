"""A costmap whose observation source topic nothing publishes says so (the BARN "blind robot" issue).

The costmap node runs as its own process on a private loopback bus; this test's peer reads
``local_costmap/sensors`` and plays the sensor: nothing at first (the source is named silent within
two seconds of the node being up, one warning in its log), then scans (ok again), then nothing (late,
with expected_update_rate set).
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import numpy as np
import yaml

from common.geometry import Transform
from common.messages import CostmapSensors, Header, LaserScan, TransformStamped
from common.tf import StaticTFBroadcaster
from tests.costmap_e2e.costmap_e2e_rig import cme_wait

TOPIC = "front/scan"  # as in the BARN benchmark's costmap files


def write_costmap_config(tmp_path: Path, expected_update_rate: float) -> Path:
    (tmp_path / "common.yaml").write_text(yaml.safe_dump({
        "robot_radius": 0.3, "transform_tolerance": 0.5, "obstacle_range": 2.5, "raytrace_range": 3.0,
        "observation_sources": "scan",
        "scan": {"data_type": "LaserScan", "topic": TOPIC, "marking": True, "clearing": True,
                 "expected_update_rate": expected_update_rate}}))
    (tmp_path / "local.yaml").write_text(yaml.safe_dump({"local_costmap": {
        "global_frame": "odom", "robot_base_frame": "base_link", "update_frequency": 5.0,
        "publish_frequency": 0.0, "rolling_window": True, "width": 4.0, "height": 4.0, "resolution": 0.1}}))
    cfg = tmp_path / "node.yaml"
    cfg.write_text(yaml.safe_dump({"name": "local_costmap", "common": "common.yaml", "specific": "local.yaml"}))
    return cfg


def start_costmap(cme_procs, env, cfg: Path):
    return cme_procs("local_costmap", [sys.executable, "-m", "master_side.costmap.node", "--config", str(cfg),
                                       "--name", "local_costmap"], env)


class Statuses:
    """Every ``local_costmap/sensors`` message with its (monotonic) receive time."""

    def __init__(self, node) -> None:
        self.items: list[tuple[float, CostmapSensors]] = []
        self.lock = threading.Lock()
        node.subscribe("local_costmap/sensors", CostmapSensors, callback=self._add, mode="queue")

    def _add(self, msg: CostmapSensors) -> None:
        with self.lock:
            self.items.append((time.monotonic(), msg))

    def __len__(self) -> int:
        with self.lock:
            return len(self.items)

    def first(self, state: str | None = None, after: int = 0):
        """(receive time, message, its one source) of the first message (from index ``after``) whose
        source is in ``state`` (any state: None)."""
        with self.lock:
            items = self.items[after:]
        for t, msg in items:
            (src,) = msg.sources
            if state is None or src.state == state:
                return t, msg, src
        return None


def warnings_about(log: str, topic: str) -> list[str]:
    return [line for line in log.splitlines() if " WARNING " in line and f"'{topic}'" in line]


def test_a_source_nothing_publishes_is_named_silent_within_two_seconds_with_one_warning(cme_bus, cme_procs,
                                                                                         tmp_path):
    node, env = cme_bus
    statuses = Statuses(node)
    costmap = start_costmap(cme_procs, env, write_costmap_config(tmp_path, expected_update_rate=0.0))
    t_up, _, first = cme_wait(lambda: statuses.first(), 60, "the costmap node's first local_costmap/sensors",
                              [costmap])
    assert first.state == "ok" and not first.delivered  # still within the grace
    t_silent, msg, src = cme_wait(lambda: statuses.first("silent"), 30, "the source reported silent", [costmap])
    assert t_silent - t_up <= 2.0, f"named silent {t_silent - t_up:.2f} s after the node was up"
    assert msg.costmap == "local_costmap"
    assert (src.source, src.topic, src.data_type, src.delivered, src.messages) == \
        ("scan", TOPIC, "LaserScan", False, 0)
    assert src.age_s <= 2.0  # since the costmap started
    assert src.expected_update_rate == 0.0
    assert src.detail.startswith(f"source 'scan' on topic '{TOPIC}' (LaserScan) has delivered nothing since start")

    # 1 Hz while nothing changes, every message still naming it; its log warned once, not every cycle
    n = len(statuses)
    cme_wait(lambda: len(statuses) >= n + 3, 30, "three more status messages", [costmap])
    with statuses.lock:
        later = statuses.items[n:]
    assert all(m.sources[0].state == "silent" for _, m in later)
    spacing = np.diff([t for t, _ in later])
    assert spacing.min() > 0.5, spacing  # not every 0.2 s check
    warnings = warnings_about(costmap.log(), TOPIC)
    assert len(warnings) == 1, costmap.log()[-3000:]
    assert "has delivered nothing since start" in warnings[0]
    assert "zenav topic list" in warnings[0]


def test_a_source_that_starts_publishing_is_ok_and_late_when_it_stops(cme_bus, cme_procs, tmp_path):
    node, env = cme_bus
    statuses = Statuses(node)
    tf = StaticTFBroadcaster(node)
    tf.send(TransformStamped(Header(0.0, "odom"), "laser", Transform()))
    costmap = start_costmap(cme_procs, env, write_costmap_config(tmp_path, expected_update_rate=0.5))
    cme_wait(lambda: statuses.first("silent"), 60, "the source reported silent", [costmap])

    pub = node.publisher(TOPIC)
    ranges = np.full(90, 1.5, np.float32)

    def scan() -> None:
        pub.publish(LaserScan(Header(time.time(), "laser"), -0.8, 0.8, 1.6 / 89, 0.0, 0.1, 0.05, 10.0, ranges))

    timer = node.timer(0.1, scan)
    try:
        n = len(statuses)
        _, _, src = cme_wait(lambda: statuses.first("ok", after=n), 30, "the source back to ok", [costmap])
        assert src.delivered and src.messages > 0
        assert src.age_s < 0.5
    finally:
        timer.cancel()
    n = len(statuses)
    _, _, src = cme_wait(lambda: statuses.first("late", after=n), 30, "the source reported late", [costmap])
    assert src.delivered and src.topic == TOPIC
    assert src.age_s > 0.5
    assert "expected_update_rate 0.5 s" in src.detail

    def log_has_all() -> bool:
        log = costmap.log()
        return "recovered" in log and any(" is late" in w for w in warnings_about(log, TOPIC))

    cme_wait(log_has_all, 30, "silent, recovered and late in the costmap's log", [costmap])
    print("\n" + "\n".join(line for line in costmap.log().splitlines() if "local_costmap:" in line))
    log = costmap.log()
    warnings = warnings_about(log, TOPIC)
    infos = [line for line in log.splitlines() if " INFO " in line and "recovered" in line]
    # one line per change of state: silent once, recovered once; late as often as it recovered from late,
    # plus the final one (a loaded machine may delay one of the 10 Hz scans past 0.5 s)
    assert len([w for w in warnings if "has delivered nothing" in w]) == 1, log[-3000:]
    assert len([i for i in infos if "(silent before)" in i]) == 1, log[-3000:]
    late = [w for w in warnings if " is late" in w]
    assert len(late) == len([i for i in infos if "(late before)" in i]) + 1, log[-3000:]
    assert len(warnings) == 1 + len(late)
    tf.close()
