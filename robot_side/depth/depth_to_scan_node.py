"""Bus adapter: ``camera/depth/image`` (DepthImage) + ``camera/depth/camera_info`` -> ``scan``."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from common.messages import CameraInfo, DepthImage
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams
from robot_side.depth.node_util import Handles, split_params

log = logging.getLogger("zenav.depth_to_scan")


@dataclass(frozen=True)
class DepthToScanTopics:
    image_topic: str = param("camera/depth/image", doc="input DepthImage")
    camera_info_topic: str = param("camera/depth/camera_info", doc="input CameraInfo")
    scan_topic: str = param("scan", doc="output LaserScan")


def start(node: Node, cfg: dict, source: str) -> Handles:
    topics, params = split_params(cfg, source, DepthToScanTopics, DepthToScanParams)
    conv = DepthToScan(params)
    h = Handles()
    pub = h.add(node.publisher(topics.scan_topic))
    info_sub = h.add(node.subscribe(topics.camera_info_topic, CameraInfo))

    def on_image(img: DepthImage) -> None:
        info = info_sub.latest()
        if info is None:
            log.debug("depth image before any camera_info: dropped")
            return
        pub.publish(conv.convert(img, info))

    # keep-latest mode: a slow conversion drops stale frames instead of queueing them
    h.add(node.subscribe(topics.image_topic, DepthImage, callback=on_image))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("depth_to_scan", start))
