"""Bus adapter: PointCloud (``camera/depth/points``) -> ``virtual_scans/<i>`` (laserscan_virtualizer).

The cloud frame is looked up in ``base_frame`` through TF (waiting up to ``tf_wait_timeout``, 3 s as
the tutorial recommends). The plane frames (``virtual_scan_<i>`` unless named) are published on
``tf_static`` under ``base_frame`` so that the merger can look them up, as the ROS launch files do
with static_transform_publisher.
"""

from __future__ import annotations

import logging
import threading

from common.bus import Node
from common.geometry import Transform
from common.messages import Header, PointCloud, TransformStamped
from common.tf import StaticTFBroadcaster, TFError, TFListener
from robot_side.depth.node_util import Handles, split_params
from robot_side.depth.virtualizer import Virtualizer, VirtualizerParams

log = logging.getLogger("zenav.virtualizer")


def start(node: Node, cfg: dict, source: str) -> Handles:
    (params,) = split_params(cfg, source, VirtualizerParams)
    h = Handles()
    tf = h.add(TFListener(node))
    static = h.add(StaticTFBroadcaster(node))
    state: dict = {"virt": None, "pubs": None}
    lock = threading.Lock()

    def setup(cloud_to_base: Transform) -> tuple[Virtualizer, list]:
        sensor = Transform(cloud_to_base.translation)  # tutorial planes: level, around the sensor origin
        planes = params.planes(sensor)
        virt = Virtualizer(planes, params)
        static.send([TransformStamped(Header(node.clock.now(), params.base_frame), fid, pl)
                     for fid, pl in zip(virt.frame_ids, planes)])
        if params.output_laser_topic:
            pubs = [node.publisher(params.output_laser_topic)] * len(planes)
        else:
            pubs = [node.publisher(f"virtual_scans/{i}") for i in range(len(planes))]
        return virt, pubs

    def on_cloud(cloud: PointCloud) -> None:
        try:
            tr = tf.buffer.lookup(params.base_frame, cloud.header.frame_id, cloud.header.stamp,
                                  timeout=params.tf_wait_timeout).transform
        except TFError as e:
            log.warning("no transform %s <- %s: %s", params.base_frame, cloud.header.frame_id, e)
            return
        with lock:
            if state["virt"] is None:
                state["virt"], state["pubs"] = setup(tr)
            virt, pubs = state["virt"], state["pubs"]
        for pub, scan in zip(pubs, virt.scans(cloud.points, cloud.header.stamp, tr)):
            pub.publish(scan)

    h.add(node.subscribe(params.cloud_topic, PointCloud, callback=on_cloud))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("laserscan_virtualizer", start))
