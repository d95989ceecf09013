"""Bus adapter: ``sonar`` (SonarArray, the P2OS driver's or the simulator's) -> ``sonar_pointcloud``
(PointCloud in the readings' frame): each sonar's echo as a point on its axis, for a costmap's obstacle layer
(robot_side/sonar/geometry.py says where and why). With ``include_no_echo`` a sonar with no echo gives a
point at the ring's maximum range, which an obstacle layer with a shorter ``obstacle_range`` only clears
along. With ``cone_topic`` the node also publishes, for a clearing-only source, points across each cone just
short of its reading (``cone_points``): what a sonar has heard empty is its whole cone, not its axis. Every
message gives a cloud, so the costmap sees the source alive."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from common.messages import PointCloud, SonarArray
from robot_side.depth.node_util import Handles, convert_stream, split_params
from robot_side.sonar.geometry import SonarRingParams, cone_points, sonar_points

log = logging.getLogger("zenav.sonar_cloud")


@dataclass(frozen=True)
class SonarCloudParams:
    sonar_topic: str = param("sonar", doc="input SonarArray")
    points_topic: str = param("sonar_pointcloud", doc="output PointCloud")
    use: tuple[int, ...] = param((), doc="the sonar numbers to use (empty: all); e.g. the rear ring 8-15 "
                                         "behind a forward laser")
    include_no_echo: bool = param(True, doc="a sonar with no echo gives a point at range_max (to clear along)")
    z: float = param(0.2, lo=-1.0, hi=2.0, unit="m", doc="height of the points (within the costmap's obstacle band)")
    cone_topic: str = param("", doc="also publish points across each cone, just short of its reading, on this "
                                    "topic (for a clearing-only source; empty: not published)")
    cone_rays: int = param(5, lo=1, hi=64, doc="bearings per cone on cone_topic")
    cone_use: tuple[int, ...] | None = param(None, doc="the sonars whose cones go on cone_topic (default: use's; "
                                                       "empty: all)")


def start(node: Node, cfg: dict, source: str) -> Handles:
    p, ring = split_params(cfg, source, SonarCloudParams, SonarRingParams)
    warned: set[int] = set()
    limit = ring.range_max * (1.0 + 1e-6) if p.include_no_echo else ring.range_max

    def cloud(msg: SonarArray) -> PointCloud:
        n = len(msg.ranges)
        if n != len(ring.units) and n not in warned:
            warned.add(n)
            log.warning("sonar has %d readings, this node's ring %d: the readings without a unit are ignored",
                        n, len(ring.units))
        return PointCloud(msg.header, sonar_points(ring, msg.ranges, p.use, p.z, max_range=limit))

    h = convert_stream(node, p.sonar_topic, SonarArray, p.points_topic, cloud)
    if p.cone_topic:
        def cones(msg: SonarArray) -> PointCloud:
            use = p.use if p.cone_use is None else p.cone_use
            return PointCloud(msg.header, cone_points(ring, msg.ranges, use, p.cone_rays, p.z))

        h.add(convert_stream(node, p.sonar_topic, SonarArray, p.cone_topic, cones))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("sonar_cloud", start))
