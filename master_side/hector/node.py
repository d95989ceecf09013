"""hector_mapping over the bus: `scan` in; latched `map`, `slam_out_pose` and TF out — map->odom
(``pub_map_odom_transform``, with odom->base_frame from TF at the scan's stamp) or map->base_frame when
there is no odom frame (``odom_frame`` empty or equal to ``base_frame``), as hector_mapping does. The
matcher never reads odometry unless ``use_tf_pose_start_estimate`` asks for the TF pose as its start.
"""

from __future__ import annotations

import threading

from common.config import load_params, strip_frame
from common.geometry import Pose2D
from common.messages import Header, LaserScan, PoseStamped, TransformStamped
from master_side.hector.params import HectorParams
from master_side.hector.slam import HectorSlam

TF_PERIOD = 0.05  # s: map->odom is re-sent at this period between scans (as slam_gmapping)


def load(cfg: dict, source: str, notes: list | None = None) -> HectorParams:
    return load_params(HectorParams, cfg, source=source, notes=notes)


def check(cfg: dict, source: str) -> list[str]:
    """Parameters checked without the bus (the agents call this before starting anything)."""
    from common.config import merge_included

    notes: list = []
    load(*merge_included(cfg, "hector", source), notes=notes)
    return notes


class HectorNode:
    def __init__(self, node, cfg: dict, source: str):
        from common.tf import TFBroadcaster, TFListener

        self.node = node
        self.p = p = load(cfg, source)
        self.base, self.map_frame = strip_frame(p.base_frame), strip_frame(p.map_frame)
        odom = strip_frame(p.odom_frame)
        self.odom = odom if odom and odom != self.base and p.pub_map_odom_transform else ""
        self.scanmatch = strip_frame(p.tf_map_scanmatch_transform_frame_name)
        self.slam: HectorSlam | None = None
        self.lock = threading.Lock()
        self.map_to_odom = Pose2D()
        self.handled = 0
        self.no_tf = 0
        self.last_map = -float("inf")
        self.tf = TFListener(node)
        self.tf_out = TFBroadcaster(node)
        self.map_pub = node.publisher("map", latched=True, reliable=True)  # a whole map: never dropped in fragments
        self.pose_pub = node.publisher("slam_out_pose")
        self.sub = node.subscribe(p.scan_topic, LaserScan, callback=self._on_scan, mode="queue",
                                  queue_size=p.scan_subscriber_queue_size)
        self.timer = node.timer(TF_PERIOD, self._publish_tf) if self.odom else None

    def _lookup(self, target: str, source: str, t: float) -> Pose2D | None:
        try:
            return self.tf.buffer.lookup(target, source, t, timeout=0.2).transform.to_pose2d()
        except Exception:  # noqa: BLE001 - any TF failure: the caller falls back
            return None

    def _on_scan(self, scan: LaserScan) -> None:
        try:
            self._process(scan)
        finally:
            self.handled += 1

    def _process(self, scan: LaserScan) -> None:
        p, t = self.p, scan.header.stamp
        laser = Pose2D()
        if p.use_tf_scan_transformation:
            laser = self._lookup(self.base, strip_frame(scan.header.frame_id) or self.base, t)
            if laser is None:  # hector drops a scan it cannot place on the robot
                self.no_tf += 1
                return
        odom_base = self._lookup(self.odom, self.base, t) if self.odom else None
        with self.lock:
            if self.slam is None:
                self.slam = HectorSlam(p, laser)
            start = None
            if p.use_tf_pose_start_estimate and odom_base is not None and self.slam.pose is not None:
                start = self.map_to_odom.compose(odom_base)
            pose = self.slam.process(t, scan, start)
            if self.odom:
                self.map_to_odom = pose.compose(odom_base.inverse()) if odom_base is not None else pose
            publish_map = t - self.last_map >= p.map_pub_period or self.slam.scans == 1
            grid = self.slam.occupancy_grid(t, self.map_frame) if publish_map else None
        tfs = [TransformStamped(Header(t, self.map_frame), self.odom or self.base,
                                (self.map_to_odom if self.odom else pose).to_transform())]
        if p.pub_map_scanmatch_transform and self.scanmatch:
            tfs.append(TransformStamped(Header(t, self.map_frame), self.scanmatch, pose.to_transform()))
        self.tf_out.send(tfs)
        self.pose_pub.publish(PoseStamped(Header(t, self.map_frame), pose.to_transform()))
        if grid is not None:
            self.last_map = t
            self.map_pub.publish(grid)

    def _publish_tf(self) -> None:
        if self.slam is None:
            return
        corr = self.map_to_odom
        self.tf_out.send(TransformStamped(Header(self.node.clock.now(), self.map_frame), self.odom,
                                          corr.to_transform()))

    def close(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
        self.sub.close()


def start(node, cfg: dict, source: str) -> HectorNode:
    """cfg: hector_mapping parameters, or ``hector: FILE`` (a parameters file) plus keys overriding it."""
    from common.config import merge_included

    return HectorNode(node, *merge_included(cfg, "hector", source))


if __name__ == "__main__":
    from common.runner import node_main

    node_main("hector_mapping", start)
