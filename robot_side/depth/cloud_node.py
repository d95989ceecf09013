"""Bus adapter: ``camera/depth/image`` + ``camera/depth/camera_info`` -> ``camera/depth/points``."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from common.messages import CameraInfo, DepthImage
from robot_side.depth.cloud import CloudParams, DepthToCloud
from robot_side.depth.node_util import Handles, split_params

log = logging.getLogger("zenav.depth_cloud")


@dataclass(frozen=True)
class CloudTopics:
    image_topic: str = param("camera/depth/image", doc="input DepthImage")
    camera_info_topic: str = param("camera/depth/camera_info", doc="input CameraInfo")
    points_topic: str = param("camera/depth/points", doc="output PointCloud (optical frame)")


def start(node: Node, cfg: dict, source: str) -> Handles:
    topics, params = split_params(cfg, source, CloudTopics, CloudParams)
    conv = DepthToCloud(params)
    h = Handles()
    pub = h.add(node.publisher(topics.points_topic))
    info_sub = h.add(node.subscribe(topics.camera_info_topic, CameraInfo))

    def on_image(img: DepthImage) -> None:
        info = info_sub.latest()
        if info is None:
            log.debug("depth image before any camera_info: dropped")
            return
        pub.publish(conv.convert(img, info))

    h.add(node.subscribe(topics.image_topic, DepthImage, callback=on_image))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("depth_cloud", start))
