"""Bus adapter (kobuki's bumper2pc): ``bumper_state`` (BumperState) -> ``bumper_pointcloud`` (PointCloud in
the bumper message's frame), a few points beyond each pressed segment for the local costmap to mark
(robot_side/bumpers/geometry.py says where and why). Every message gives a cloud, an empty one when nothing
is pressed, so the costmap sees the source alive."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from common.messages import BumperState, PointCloud
from robot_side.bumpers.geometry import BumperParams, press_points
from robot_side.depth.node_util import Handles, convert_stream, split_params

log = logging.getLogger("zenav.bumper_cloud")


@dataclass(frozen=True)
class BumperCloudParams:
    state_topic: str = param("bumper_state", doc="input BumperState (the base driver's, or the simulator's)")
    points_topic: str = param("bumper_pointcloud", doc="output PointCloud")
    offset: float = param(0.08, lo=0.0, hi=1.0, unit="m",
                          doc="points this far beyond a pressed segment's face: outside the footprint and its "
                              "padding (zenav's P3-AT local costmaps pad 0.04 m), which an obstacle layer clears")
    z: float = param(0.1, lo=-1.0, hi=2.0, unit="m", doc="height of the points (within the costmap's obstacle band)")


def start(node: Node, cfg: dict, source: str) -> Handles:
    p, geometry = split_params(cfg, source, BumperCloudParams, BumperParams)
    warned: set[int] = set()

    def cloud(msg: BumperState) -> PointCloud:
        for n in {len(msg.front_bumpers), len(msg.rear_bumpers)} - {0, geometry.segments} - warned:
            warned.add(n)
            log.warning("bumper_state has %d segments, this node's geometry %d: the extra ones are ignored",
                        n, geometry.segments)
        return PointCloud(msg.header, press_points(geometry, msg.front_bumpers, msg.rear_bumpers, p.offset, p.z))

    return convert_stream(node, p.state_topic, BumperState, p.points_topic, cloud)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("bumper_cloud", start))
