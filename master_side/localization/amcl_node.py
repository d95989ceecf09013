"""amcl over the bus: latched ``map``, ``scan``, TF odom→base_link and base_link→scan frame in;
``amcl_pose`` (PoseStamped, map) and TF map→odom out; ``initialpose`` (PoseStamped, like rviz's 2D
Pose Estimate) and the ``global_localization`` service (Empty → Empty) re-seed the particles.

map→odom is republished every ``transform_publish_period`` seconds (default 0.05), stamped
``now + transform_tolerance`` as ROS amcl future-dates it, from a value swapped in after each
filter update (with zenav's ``refine_pose``, after every scan; ``amcl_pose`` too, while the particle
cloud is published at filter updates only): the TF keeps flowing while a scan is being processed.
"""

from __future__ import annotations

import logging
import threading

from common.config import Problems, load_params, merge_included, strip_frame
from common.geometry import Pose2D
from common.messages import Empty, Header, LaserScan, OccupancyGrid, Path, PoseStamped, TransformStamped
from master_side.localization.amcl import Amcl
from master_side.localization.params import UNUSED, AmclParams

log = logging.getLogger("zenav.amcl")
NODE_ONLY = ("transform_publish_period",)


def load(cfg: dict, source: str, notes: list[str] | None = None) -> tuple[AmclParams, float]:
    """The filter parameters and the TF period; every problem in one ConfigError. ROS amcl keys zenav
    does not use (``UNUSED``) are accepted and listed in ``notes``."""
    problems, p = Problems(), None
    with problems.collect():
        p = load_params(AmclParams, cfg, source=source, ignore=NODE_ONLY, notes=notes,
                        no_effect={k: "no effect (not implemented in zenav)" for k in UNUSED})
    period = cfg.get("transform_publish_period", 0.05)
    if isinstance(period, bool) or not isinstance(period, (int, float)) or not 0 <= period <= 10:
        problems.add(source, "transform_publish_period", f"{period!r}: must be in [0, 10] s")
    problems.raise_if_any()
    return p, float(period)


def check(cfg: dict, source: str) -> list[str]:
    """Parameters checked without the bus (the agents call this before starting anything)."""
    notes: list[str] = []
    load(*merge_included(cfg, "amcl", source), notes=notes)
    return notes


class AmclNode:
    def __init__(self, node, cfg: dict, source: str) -> None:
        from common.tf import TFBroadcaster, TFListener

        self.node = node
        self.p, period = load(cfg, source)
        self.map_frame = strip_frame(self.p.global_frame_id)
        self.odom_frame = strip_frame(self.p.odom_frame_id)
        self.base_frame = strip_frame(self.p.base_frame_id)
        self.filter: Amcl | None = None
        self.lock = threading.Lock()  # guards self.filter (scan updates vs. re-seeding)
        self._corr: Pose2D | None = None  # map -> odom, replaced (never mutated) after each update
        self.tf = TFListener(node)
        self.tf_out = TFBroadcaster(node)
        self.pose_pub = node.publisher("amcl_pose")
        self.cloud_pub = node.publisher("particlecloud")  # ROS amcl's particlecloud: rows x, y, yaw (map)
        self.subs = [
            node.subscribe("map", OccupancyGrid, callback=self._on_map, mode="latest"),
            node.subscribe("scan", LaserScan, callback=self._on_scan, mode="latest"),
            node.subscribe("initialpose", PoseStamped, callback=self._on_initial_pose, mode="queue"),
        ]
        node.service("set_initial_pose", self._set_initial_pose, request_type=PoseStamped)  # acknowledged
        node.service("global_localization", self._on_global_localization, request_type=Empty)
        self.timer = node.timer(float(period), self._publish_tf) if period > 0 else None

    # -- inputs ----------------------------------------------------------------------------------------
    def _on_map(self, grid: OccupancyGrid) -> None:
        with self.lock:
            old = self.filter
            try:
                new = Amcl(self.p, grid)
            except ValueError as e:
                log.error("map rejected: %s", e)
                return
            if old is not None:  # keep the current belief on a new map (as a Gaussian)
                mean, cov = old.estimate()
                new.init_pose(mean, (cov[0, 0], cov[1, 1], cov[2, 2]))
            self.filter = new
        log.info("map %dx%d at %.3f m: %d particles", grid.width, grid.height, grid.resolution,
                 len(new.poses))

    def _on_scan(self, scan: LaserScan) -> None:
        t = scan.header.stamp
        try:
            odom = self.tf.buffer.lookup_pose2d(self.odom_frame, self.base_frame, t, timeout=0.2)
            laser = self.tf.buffer.lookup(self.base_frame, strip_frame(scan.header.frame_id), t, timeout=0.2)
        except LookupError as e:  # no TF for this scan yet: ROS amcl drops it too
            log.debug("scan at %.3f dropped: %s", t, e)
            return
        with self.lock:
            f = self.filter
            if f is None:
                return
            sideways = f.sideways_increments
            ran = f.update(odom, scan, laser.transform.to_pose2d())
            if f.sideways_increments and not sideways:
                log.warning("the odometry moved base_link sideways (at %.3f): odom_model_type %s reads that as a "
                            "turn, a drive and a turn back and may lose the robot; a base whose odometry turns "
                            "it about a point off base_link needs odom_model_type omni", t, self.p.odom_model_type)
            if not ran and not self.p.refine_pose:
                return
            corr, (mean, _) = f.map_to_odom(), f.estimate()
            cloud = f.poses.copy() if ran else None
        if corr is None:
            return
        self._corr = corr
        self.pose_pub.publish(PoseStamped(Header(t, self.map_frame), mean.to_transform()))
        if cloud is not None:  # the particles move only at a filter update
            self.cloud_pub.publish(Path(Header(t, self.map_frame), cloud))

    def _on_initial_pose(self, msg: PoseStamped) -> None:
        try:
            self._set_initial_pose(msg)
        except (LookupError, RuntimeError) as e:
            log.warning("initialpose ignored: %s", e)

    def _set_initial_pose(self, msg: PoseStamped) -> PoseStamped:
        """``initialpose`` (topic) and ``set_initial_pose`` (service: the pose set, in the map frame, or
        the reason it was not)."""
        frame = strip_frame(msg.header.frame_id) or self.map_frame
        pose = msg.pose.to_pose2d()
        if frame != self.map_frame:
            try:
                pose = self.tf.buffer.lookup_pose2d(self.map_frame, frame, 0.0, timeout=0.5).compose(pose)
            except LookupError as e:
                raise LookupError(f"no transform {self.map_frame} <- {frame}: {e}") from None
        with self.lock:
            if self.filter is None:
                raise RuntimeError("no map received yet")
            self.filter.init_pose(pose, (self.p.initial_cov_xx, self.p.initial_cov_yy, self.p.initial_cov_aa))
            cloud = self.filter.poses.copy()
        self.cloud_pub.publish(Path(Header(msg.header.stamp, self.map_frame), cloud))
        log.info("initial pose set to (%.2f, %.2f, %.2f)", pose.x, pose.y, pose.theta)
        return PoseStamped(Header(msg.header.stamp, self.map_frame), pose.to_transform())

    def _on_global_localization(self, _req: Empty) -> Empty:
        with self.lock:
            if self.filter is None:
                raise RuntimeError("no map yet")
            self.filter.global_localization()
        log.info("global localisation: %d particles over the free space", self.p.max_particles)
        return Empty()

    # -- output ----------------------------------------------------------------------------------------
    def _publish_tf(self) -> None:
        corr = self._corr  # no lock: the TF keeps flowing while a scan is being processed
        if corr is None:
            return
        stamp = self.node.clock.now() + self.p.transform_tolerance
        header = Header(stamp, self.map_frame)
        self.tf_out.send(TransformStamped(header, self.odom_frame, corr.to_transform()))

    def close(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
        for s in self.subs:
            s.close()
        self.tf.close()


def start(node, cfg: dict, source: str) -> AmclNode:
    """cfg: ROS amcl parameters, or ``amcl: FILE`` (an amcl parameter file) plus keys overriding it."""
    return AmclNode(node, *merge_included(cfg, "amcl", source))


if __name__ == "__main__":
    from common.runner import node_main

    node_main("amcl", start)
