"""Bus adapter: ``camera/depth/image`` + ``camera/depth/camera_info`` -> ``camera/depth/points``."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from robot_side.depth.cloud import CloudParams, DepthToCloud
from robot_side.depth.node_util import Handles, convert_depth_stream, split_params

log = logging.getLogger("zenav.depth_cloud")


@dataclass(frozen=True)
class CloudTopics:
    image_topic: str = param("camera/depth/image", doc="input DepthImage")
    camera_info_topic: str = param("camera/depth/camera_info", doc="input CameraInfo")
    points_topic: str = param("camera/depth/points", doc="output PointCloud (optical frame)")


def start(node: Node, cfg: dict, source: str) -> Handles:
    topics, params = split_params(cfg, source, CloudTopics, CloudParams)
    return convert_depth_stream(node, topics.image_topic, topics.camera_info_topic, topics.points_topic,
                                DepthToCloud(params).convert, log)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("depth_cloud", start))
