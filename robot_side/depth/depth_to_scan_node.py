"""Bus adapter: ``camera/depth/image`` (DepthImage) + ``camera/depth/camera_info`` -> ``scan``."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams
from robot_side.depth.node_util import Handles, convert_depth_stream, split_params

log = logging.getLogger("zenav.depth_to_scan")


@dataclass(frozen=True)
class DepthToScanTopics:
    image_topic: str = param("camera/depth/image", doc="input DepthImage")
    camera_info_topic: str = param("camera/depth/camera_info", doc="input CameraInfo")
    scan_topic: str = param("scan", doc="output LaserScan")


def start(node: Node, cfg: dict, source: str) -> Handles:
    topics, params = split_params(cfg, source, DepthToScanTopics, DepthToScanParams)
    return convert_depth_stream(node, topics.image_topic, topics.camera_info_topic, topics.scan_topic,
                                DepthToScan(params).convert, log)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("depth_to_scan", start))
