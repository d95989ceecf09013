"""slam_gmapping over the bus: `scan` + TF odom→base_link in, latched `map` and TF map→odom out."""

from __future__ import annotations

import threading

from common.config import load_params, strip_frame
from common.geometry import Pose2D
from common.messages import Header, LaserScan, TransformStamped
from master_side.slam.gridslam import GridSlam
from master_side.slam.params import NODE_ONLY, GMappingParams


class SlamNode:
    def __init__(self, node, cfg: dict, source: str):
        self.node = node
        self.params = load_params(GMappingParams, cfg, source=source, ignore=NODE_ONLY)
        self.base = strip_frame(str(cfg.get("base_frame", "base_link")))
        self.odom = strip_frame(str(cfg.get("odom_frame", "odom")))
        self.map_frame = strip_frame(str(cfg.get("map_frame", "map")))
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
        period = float(cfg.get("transform_publish_period", 0.05))
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
