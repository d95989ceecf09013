"""Bus adapter: the scans in ``laserscan_topics`` -> ``scan`` + ``merged_cloud`` (laserscan_multi_merger).

Each scan's frame is looked up in ``destination_frame`` at the scan stamp, waiting up to
``tf_wait_timeout`` (the tutorial raised the ROS node's 1 s to 3 s). A merge is published when
every live input has delivered a new scan (inputs silent for ``max_scan_age`` do not block it).
"""

from __future__ import annotations

import logging
import threading

from common.bus import Node
from common.messages import LaserScan
from common.tf import TFError, TFListener
from robot_side.depth.merger import MergerParams, ScanMerger
from robot_side.depth.node_util import Handles, split_params

log = logging.getLogger("zenav.merger")


def start(node: Node, cfg: dict, source: str) -> Handles:
    (params,) = split_params(cfg, source, MergerParams)
    h = Handles()
    tf = h.add(TFListener(node))
    merger = ScanMerger(params)
    lock = threading.Lock()
    scan_pub = h.add(node.publisher(params.scan_destination_topic))
    cloud_pub = h.add(node.publisher(params.cloud_destination_topic))

    def on_scan(topic: str, scan: LaserScan) -> None:
        try:
            tr = tf.buffer.lookup(params.destination_frame, scan.header.frame_id, scan.header.stamp,
                                  timeout=params.tf_wait_timeout).transform
        except TFError as e:
            log.warning("no transform %s <- %s: %s", params.destination_frame, scan.header.frame_id, e)
            return
        with lock:
            merger.update(topic, scan, tr)
            out = merger.merge(now=scan.header.stamp) if merger.ready(scan.header.stamp) else None
        if out is not None:
            scan_pub.publish(out[0])
            cloud_pub.publish(out[1])

    for topic in merger.topics:
        h.add(node.subscribe(topic, LaserScan, callback=lambda s, t=topic: on_scan(t, s)))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("laserscan_multi_merger", start))
