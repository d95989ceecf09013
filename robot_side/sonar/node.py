"""Bus adapter: ``sonar`` (SonarArray, the P2OS driver's or the simulator's) -> ``sonar_pointcloud``
(PointCloud in the readings' frame): each sonar's echo as a point on its axis, for a costmap's obstacle layer
(robot_side/sonar/geometry.py says where and why). With ``include_no_echo`` a sonar with no echo gives a
point at the ring's maximum range, which an obstacle layer with a shorter ``obstacle_range`` only clears
along. With ``cone_topic`` the node also publishes, for a clearing-only source, points across each cone just
short of its reading (``cone_points``): what a sonar has heard empty is its whole cone, not its axis. Every
message gives a cloud, so the costmap sees the source alive.

With ``frame_prefix`` each sonar's points go out as a message of their own, in the sonar's own frame
(``<prefix><number>``, sent as static transforms from the readings' frame by the ring's geometry), as ROS
gives each sonar a frame for its Range messages. An obstacle layer raytraces from a cloud's frame origin
(a source without ``sensor_frame``), so it then clears from the sonar itself. From the base's centre, the
line to a point of a side sonar's cone runs outside the cone for its first centimetres beyond the body:
it erased the marks of a door jamb's corner that no sonar had heard empty (office02, 2026-11-29: the rear
corner of a robot turning round the jamb then struck it)."""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

from common.bus import Node
from common.config import param
from common.geometry import Quaternion, Transform, Vector3
from common.messages import Header, PointCloud, SonarArray, TransformStamped
from common.tf import StaticTFBroadcaster
from robot_side.depth.node_util import Handles, convert_stream, split_params
from robot_side.sonar.geometry import SonarRingParams, cone_points, sonar_points, used_sonars

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
    near: tuple[int, ...] = param((), doc="sonars of use's whose echoes go on points_topic only nearer than "
                                          "near_range (farther, they give no point; their cones still clear)")
    near_range: float = param(0.5, lo=0.05, hi=50.0, unit="m",
                              doc="near's range: an echo there is placed on the axis within "
                                  "near_range * sin(fov / 2) of where it came from")
    frame_prefix: str = param("", doc="publish each sonar's points as their own message in the sonar's own frame "
                                      "<prefix><number> (static transforms from the readings' frame, at height z): "
                                      "a costmap then raytraces from the sonar, not from the base's centre "
                                      "(empty: one cloud per reading, in the readings' frame)")

    @property
    def cones(self) -> tuple[int, ...]:
        """The sonars whose cones go on cone_topic (cone_use, default use's; empty: all)."""
        return self.use if self.cone_use is None else self.cone_use


def start(node: Node, cfg: dict, source: str) -> Handles:
    p, ring = split_params(cfg, source, SonarCloudParams, SonarRingParams)
    warned: set[int] = set()
    limit = ring.range_max * (1.0 + 1e-6) if p.include_no_echo else ring.range_max

    def check(msg: SonarArray) -> tuple[float, ...]:
        """The readings for points_topic (near's far echoes dropped), after a word on a ring that differs."""
        n = len(msg.ranges)
        if n != len(ring.units) and n not in warned:
            warned.add(n)
            log.warning("sonar has %d readings, this node's ring %d: the readings without a unit are ignored",
                        n, len(ring.units))
        return tuple(math.nan if k in p.near and not r < p.near_range else r for k, r in enumerate(msg.ranges))

    if p.frame_prefix:
        return _per_sonar(node, p, ring, limit, check)

    def cloud(msg: SonarArray) -> PointCloud:
        return PointCloud(msg.header, sonar_points(ring, check(msg), p.use, p.z, max_range=limit))

    h = convert_stream(node, p.sonar_topic, SonarArray, p.points_topic, cloud)
    if p.cone_topic:
        def cones(msg: SonarArray) -> PointCloud:
            return PointCloud(msg.header, cone_points(ring, msg.ranges, p.cones, p.cone_rays, p.z))

        h.add(convert_stream(node, p.sonar_topic, SonarArray, p.cone_topic, cones))
    return h


def sonar_frames(ring: SonarRingParams, parent: str, prefix: str, numbers: list[int],
                 z: float) -> list[TransformStamped]:
    """Static transforms ``parent`` -> ``<prefix><k>`` for the sonars ``numbers``: at the unit, at height
    ``z``, x along its axis."""
    return [TransformStamped(Header(0.0, parent), f"{prefix}{k}",
                             Transform(Vector3(ring.units[k][0], ring.units[k][1], z),
                                       Quaternion.from_yaw(ring.units[k][2])))
            for k in numbers]


def _per_sonar(node: Node, p: SonarCloudParams, ring: SonarRingParams, limit: float, check) -> Handles:
    """One message per sonar and reading, in the sonar's own frame (``frame_prefix``)."""
    axis = used_sonars(p.use, len(ring.units))
    cones = used_sonars(p.cones, len(ring.units)) if p.cone_topic else []
    one = dataclasses.replace(ring, units=((0.0, 0.0, 0.0),))  # a sonar seen from its own frame
    h = Handles()
    points_pub = h.add(node.publisher(p.points_topic))
    cone_pub = h.add(node.publisher(p.cone_topic)) if cones else None
    static = h.add(StaticTFBroadcaster(node))
    sent: set[str] = set()

    def on_sonar(msg: SonarArray) -> None:
        marked = check(msg)
        parent = msg.header.frame_id
        if parent not in sent:
            sent.add(parent)
            static.send(sonar_frames(ring, parent, p.frame_prefix, sorted(set(axis) | set(cones)), p.z))
        readings = list(msg.ranges)
        for k in axis:
            reading = (marked[k] if k < len(marked) else math.nan,)
            points_pub.publish(PointCloud(Header(msg.header.stamp, f"{p.frame_prefix}{k}"),
                                          sonar_points(one, reading, (), 0.0, max_range=limit)))
        for k in cones:
            reading = (readings[k] if k < len(readings) else math.nan,)
            cone_pub.publish(PointCloud(Header(msg.header.stamp, f"{p.frame_prefix}{k}"),
                                        cone_points(one, reading, (), p.cone_rays, 0.0)))

    h.add(node.subscribe(p.sonar_topic, SonarArray, callback=on_sonar, mode="queue"))
    return h


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("sonar_cloud", start))
