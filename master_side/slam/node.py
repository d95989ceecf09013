"""slam_gmapping over the bus: `scan` + TF odom→base_link in, latched `map` and TF map→odom out."""

from __future__ import annotations

import threading
from dataclasses import dataclass

from common.config import Problems, load_params, param, strip_frame
from common.geometry import Pose2D
from common.messages import Header, LaserScan, TransformStamped
from master_side.slam.gridslam import GridSlam
from master_side.slam.params import NODE_ONLY, GMappingParams


@dataclass(frozen=True)
class SlamNodeParams:
    """slam_gmapping's node-level parameters that this node reads (the rest are GMappingParams)."""

    base_frame: str = param("base_link")
    odom_frame: str = param("odom")
    map_frame: str = param("map")
    transform_publish_period: float = param(0.05, lo=0.0, hi=10.0, unit="s", doc="map->odom TF period (0: off)")


NODE_KEYS = tuple(SlamNodeParams.__dataclass_fields__)
UNUSED_NODE_KEYS = tuple(k for k in NODE_ONLY if k not in NODE_KEYS)  # slam_gmapping's, not read here


def load(cfg: dict, source: str, notes: list[str] | None = None) -> tuple[GMappingParams, SlamNodeParams]:
    """GMapping and node parameters; every problem in one ConfigError; unused gmapping node keys in notes."""
    problems, gm, nodep = Problems(), None, None
    with problems.collect():
        gm = load_params(GMappingParams, cfg, source=source, ignore=NODE_KEYS, notes=notes,
                         no_effect={k: "no effect (not implemented in zenav)" for k in UNUSED_NODE_KEYS})
    with problems.collect():
        nodep = load_params(SlamNodeParams, {k: v for k, v in cfg.items() if k in NODE_KEYS}, source=source)
    problems.raise_if_any()
    return gm, nodep


def check(cfg: dict, source: str) -> list[str]:
    """Parameters checked without the bus (the agents call this before starting anything)."""
    from common.config import merge_included

    notes: list[str] = []
    load(*merge_included(cfg, "gmapping", source), notes=notes)
    return notes


class SlamNode:
    def __init__(self, node, cfg: dict, source: str):
        self.node = node
        self.params, np_ = load(cfg, source)
        self.base = strip_frame(np_.base_frame)
        self.odom = strip_frame(np_.odom_frame)
        self.map_frame = strip_frame(np_.map_frame)
        self.slam: GridSlam | None = None
        self.lock = threading.Lock()
        self.last_map = -float("inf")
        self._corr = Pose2D()  # map -> odom, replaced (not mutated) after each update
        from common.tf import TFBroadcaster, TFListener

        self.tf = TFListener(node)
        self.tf_out = TFBroadcaster(node)
        self.map_pub = node.publisher("map", latched=True)
        # keep-latest: while a scan is being processed newer ones replace older ones (no backlog)
        self.sub = node.subscribe("scan", LaserScan, callback=self._on_scan, mode="latest")
        period = np_.transform_publish_period
        self.timer = node.timer(period, self._publish_tf) if period > 0 else None

    def _on_scan(self, scan: LaserScan) -> None:
        t = scan.header.stamp
        try:
            odom = self.tf.buffer.lookup(self.odom, self.base, t, timeout=0.2).transform.to_pose2d()
            laser = self.tf.buffer.lookup(self.base, strip_frame(scan.header.frame_id), t, timeout=0.2)
        except Exception:  # no TF yet: gmapping drops the scan too
            return
        with self.lock:
            if self.slam is None:
                self.slam = GridSlam(self.params, laser=laser.transform.to_pose2d())
            updated = self.slam.process(t, odom, scan)
            self._corr = self.slam.map_to_odom()
            publish_map = updated and t - self.last_map >= self.params.map_update_interval
            grid = self.slam.occupancy_grid(t, self.map_frame) if publish_map else None
        if grid is not None:
            self.last_map = t
            self.map_pub.publish(grid)

    def _publish_tf(self) -> None:
        corr = self._corr  # no lock: the TF must keep flowing while a scan is being processed
        stamp = self.node.clock.now()
        self.tf_out.send(TransformStamped(Header(stamp, self.map_frame), self.odom, corr.to_transform()))

    def close(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
        self.sub.close()


def start(node, cfg: dict, source: str) -> SlamNode:
    """cfg: slam_gmapping parameters, or ``gmapping: FILE`` (the parameters file, e.g. the tutorial's)
    plus keys that override it."""
    from common.config import merge_included

    return SlamNode(node, *merge_included(cfg, "gmapping", source))


if __name__ == "__main__":
    from common.runner import node_main

    node_main("slam_gmapping", start)
