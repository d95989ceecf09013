"""slam_gmapping over the bus: `scan` + TF odom→base_link in, latched `map` and TF map→odom out.

Scans wait in a bounded queue (ROS: the tf MessageFilter's queue of 5; ``scan_queue_size``), the oldest
dropped and counted (`zenav nodes --stats`) when the filter falls behind. As in the MessageFilter, a scan
waits for the odometry transform at its stamp until it comes, until the queue behind it is full, or
for ``TF_WAIT_S`` (clock or wall seconds; a log's odometry may come a few tenths after a scan). The service
``<node>/trajectory`` (request Empty) answers, once the queued scans are processed, the pose of every
scan the filter was given, computed as `zenav slam run` does (a TFMessage: map -> base_link per scan
stamp; ``master_side.slam.trajectory``), so `zenav play LOG --trajectory OUT.txt` can write it.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from common.config import Problems, load_params, param, strip_frame
from common.geometry import Pose2D
from common.log_util import RateLimitedLog
from common.messages import Header, LaserScan, TFMessage, TransformStamped
from master_side.slam.gridslam import GridSlam
from master_side.slam.params import NODE_ONLY, GMappingParams
from master_side.slam.trajectory import ScanLog, to_message
from master_side.slam.warmup import warm_filter

TF_CACHE_S = 60.0


@dataclass(frozen=True)
class SlamNodeParams:
    """slam_gmapping's node-level parameters that this node reads (the rest are GMappingParams)."""

    base_frame: str = param("base_link")
    odom_frame: str = param("odom")
    map_frame: str = param("map")
    transform_publish_period: float = param(0.05, lo=0.0, hi=10.0, unit="s", doc="map->odom TF period (0: off)")
    # zenav's own: ROS hard-codes the queue (5) and has no offline refinement
    scan_queue_size: int = param(5, lo=1, hi=10000, doc="scans waiting for the filter; older ones are dropped "
                                 "(counted). ROS slam_gmapping's tf MessageFilter holds 5")
    track_between: bool = param(False, doc="scan-match every skipped scan against the best map for the "
                                "trajectory service, as `zenav slam run` does (costs CPU; no effect on the map)")


TF_WAIT_S = 5.0
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


def master_params(master_config: str, name: str = "slam_gmapping", sets: tuple[str, ...] = ()) -> GMappingParams:
    """The gmapping parameters ``zenav master --config master_config --set NAME.KEY=VALUE ...`` gives node
    ``name`` (the agent's own loading: includes, relative files, value parsing), e.g. to map a recording
    offline as that master would online."""
    from common.config import merge_included
    from master_side import agent as master_agent

    launch = master_agent.load(master_config, sets=sets)
    cfg, source = launch.node_params(launch.entry(name))
    return load(*merge_included(cfg, "gmapping", source))[0]


class SlamNode:
    def __init__(self, node, cfg: dict, source: str):
        self.node = node
        self.params, np_ = load(cfg, source)
        self.base = strip_frame(np_.base_frame)
        self.odom = strip_frame(np_.odom_frame)
        self.map_frame = strip_frame(np_.map_frame)
        self.slam: GridSlam | None = None
        self.track_between = np_.track_between
        self.queue_size = np_.scan_queue_size
        self.scans = ScanLog()  # stamp + odometry of every scan given to the filter (the trajectory's)
        self.handled = 0  # scan callbacks finished (processed or dropped for want of TF)
        self.no_tf = 0  # scans dropped: no transform at their stamp
        self._warn = RateLimitedLog()
        self.idle = threading.Condition()
        self.lock = threading.Lock()
        self.last_map = -float("inf")
        self._corr = Pose2D()  # map -> odom, replaced (not mutated) after each update
        from common.tf import TFBroadcaster, TFListener

        # 60 s of TF history (ROS: 10 s): a scan that waited in a long queue (scan_queue_size, a log played
        # faster than the filter runs) still finds the odometry at its stamp
        self.tf = TFListener(node, cache_time=TF_CACHE_S)
        self.tf_out = TFBroadcaster(node)
        self.map_pub = node.publisher("map", latched=True, reliable=True)  # a whole map: never dropped in fragments
        # the kernels load now, not in the first update: a stall there is a gap in the scans (warmup.py)
        t0 = time.monotonic()
        warm_filter()
        node.log.info("filter kernels ready in %.1f s", time.monotonic() - t0)
        # bounded queue, as ROS's MessageFilter: every scan is processed unless the filter falls behind
        self.sub = None  # _lookup reads its counters; a scan can come in before subscribe() returns
        self.sub = node.subscribe("scan", LaserScan, callback=self._on_scan, mode="queue",
                                  queue_size=np_.scan_queue_size)
        period = np_.transform_publish_period
        self.timer = node.timer(period, self._publish_tf) if period > 0 else None
        node.service(f"{node.name}/trajectory", self._trajectory)

    def _on_scan(self, scan: LaserScan) -> None:
        try:
            self._process(scan)
        finally:
            with self.idle:
                self.handled += 1
                self.idle.notify_all()

    def _process(self, scan: LaserScan) -> None:
        t = scan.header.stamp
        try:
            odom = self._lookup(self.odom, self.base, t).transform.to_pose2d()
            laser = self._lookup(self.base, strip_frame(scan.header.frame_id), t)
        except Exception as e:  # no TF: gmapping drops the scan too (its MessageFilter says so; so do we)
            self.no_tf += 1
            self._warn(self.node.log, f"scan at {t:.3f} dropped (#{self.no_tf}): no transform at its stamp: {e}")
            return
        with self.lock:
            if self.slam is None:
                self.slam = GridSlam(self.params, laser=laser.transform.to_pose2d(), track_between=self.track_between)
            self.scans.add(t, odom)
            updated = self.slam.process(t, odom, scan)
            self._corr = self.slam.map_to_odom()
            publish_map = updated and t - self.last_map >= self.params.map_update_interval
            grid = self.slam.occupancy_grid(t, self.map_frame) if publish_map else None
        if grid is not None:
            self.last_map = t
            self.map_pub.publish(grid)

    def _lookup(self, target: str, source: str, t: float):
        """The transform at ``t``, waiting as the tf MessageFilter does (see the module docstring)."""
        clock0, wall0 = self.node.clock.now(), time.monotonic()
        while True:
            try:
                return self.tf.buffer.lookup(target, source, t)
            except Exception as e:
                sub = self.sub
                waiting = sub.received - sub.dropped - self.handled - 1 if sub else 0  # scans queued behind
                # "into the past": older than every transform held, waiting cannot help
                if ("into the past" in str(e) or waiting >= self.queue_size
                        or self.node.clock.now() - clock0 > TF_WAIT_S or time.monotonic() - wall0 > TF_WAIT_S):
                    raise
                time.sleep(0.005)  # not the buffer's timed wait: a log's clock may have stopped

    def _publish_tf(self) -> None:
        corr = self._corr  # no lock: the TF must keep flowing while a scan is being processed
        stamp = self.node.clock.now()
        self.tf_out.send(TransformStamped(Header(stamp, self.map_frame), self.odom, corr.to_transform()))

    def _trajectory(self, _request) -> TFMessage:
        """Every scan's pose, once the scans received so far are processed (waiting while they are: a
        scan whose transform never comes holds the queue until the clock moves on)."""
        with self.idle:
            handled, since = self.handled, time.monotonic()
            while self.handled + self.sub.dropped < self.sub.received and time.monotonic() - since < 5.0:
                self.idle.wait(0.1)
                if self.handled != handled:
                    handled, since = self.handled, time.monotonic()
        with self.lock:
            stamps, poses = list(self.scans.stamps), self.scans.poses(self.slam)
        return to_message(stamps, poses, self.map_frame, self.base)

    def close(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
        self.sub.close()


def warm_before_fork() -> None:
    """(common.fork_server) The filter's compiled kernels, loaded once for every SLAM node forked after."""
    warm_filter()


def start(node, cfg: dict, source: str) -> SlamNode:
    """cfg: slam_gmapping parameters, or ``gmapping: FILE`` (the parameters file, e.g. the tutorial's)
    plus keys that override it."""
    from common.config import merge_included

    return SlamNode(node, *merge_included(cfg, "gmapping", source))


if __name__ == "__main__":
    from common.runner import node_main

    node_main("slam_gmapping", start)
