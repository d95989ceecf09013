"""The monitor: a Zenoh peer that logs one robot's topics to Rerun (our rviz).

It subscribes once to ``zenav/<robot>/**`` and dispatches on the decoded message type, so new
topics show up without configuration. Heavy streams are throttled per entity (rates configurable)
so a long run keeps the viewer's memory bounded. Time comes from the message stamps.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field

import rerun as rr
import rerun.blueprint as rrb
import zenoh

from common import messages as m
from common.codec import DecodeError, decode
from deploy.monitor import loggers as L

log = logging.getLogger("zenav.monitor")

# Default max logging rate per message type (Hz); 0 = every message.
DEFAULT_RATES: dict[str, float] = {
    "OccupancyGrid": 0.5, "Costmap": 2.0, "PointCloud": 2.0, "DepthImage": 2.0, "LaserScan": 10.0,
    "Odometry": 10.0, "Twist": 20.0, "Path": 5.0, "PolygonStamped": 5.0, "TFMessage": 20.0,
}
IGNORED = {"Clock", "CameraInfo", "Empty"}


@dataclass
class MonitorStats:
    received: int = 0
    logged: int = 0
    throttled: int = 0
    malformed: int = 0
    by_entity: dict = field(default_factory=dict)


def blueprint() -> rrb.Blueprint:
    """The layout: map view (map frame), local view (odom frame), depth, plots and logs."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="Map (map frame)", origin="/", contents=["/world/**", "/tf/**"],
                              spatial_information=rrb.SpatialInformation(target_frame="map")),
            rrb.Vertical(
                rrb.Spatial3DView(name="Local (odom frame)", origin="/",
                                  contents=["/world/local_costmap/**", "/world/scan", "/world/footprint/**",
                                            "/world/move_base/**", "/world/camera/**", "/tf/**",
                                            "/world/odom_trail"],
                                  spatial_information=rrb.SpatialInformation(target_frame="odom")),
                rrb.Tabs(rrb.Spatial2DView(name="Depth", origin="/camera"),
                         rrb.TimeSeriesView(name="cmd_vel", origin="/plots/cmd_vel"),
                         rrb.TimeSeriesView(name="loop times & metrics", origin="/plots")),
                rrb.TextLogView(name="Events", origin="/log"),
                row_shares=[3, 2, 2]),
            column_shares=[3, 2]),
        collapse_panels=True)


class Monitor:
    def __init__(self, session: zenoh.Session, robot: str, rec: rr.RecordingStream,
                 rates: dict[str, float] | None = None) -> None:
        self.robot, self.rec = robot, rec
        self.rates = dict(DEFAULT_RATES, **(rates or {}))
        self.stats = MonitorStats()
        self._last_log: dict[str, float] = {}
        self._last_text: dict[str, str] = {}
        self._trail = L.OdomTrail()
        self._lock = threading.Lock()
        self._prefix = f"zenav/{robot}/"
        self._sub = session.declare_subscriber(f"zenav/{robot}/**", self._on_sample)
        # Latched topics (map, tf_static) published before we started.
        session.get(f"zenav/{robot}/**", self._on_reply, target=zenoh.QueryTarget.ALL)

    def _on_reply(self, reply) -> None:
        if reply.ok is not None:
            self._on_sample(reply.ok)

    def _on_sample(self, sample) -> None:
        key = str(sample.key_expr)
        if "/srv/" in key:
            return
        topic = key[len(self._prefix):]
        try:
            msg = decode(sample.payload.to_bytes())
        except DecodeError:
            self.stats.malformed += 1
            return
        self.stats.received += 1
        try:
            with self._lock:
                self.handle(topic, msg)
        except Exception as e:  # a logging bug must not kill the monitor
            log.warning("could not log %s (%s): %s", topic, type(msg).__name__, e)

    def _due(self, entity: str, kind: str) -> bool:
        hz = self.rates.get(kind, 0.0)
        now = time.monotonic()
        if hz > 0 and now - self._last_log.get(entity, -1e9) < 1.0 / hz:
            self.stats.throttled += 1
            return False
        self._last_log[entity] = now
        self.stats.logged += 1
        self.stats.by_entity[entity] = self.stats.by_entity.get(entity, 0) + 1
        return True

    def _time(self, stamp: float) -> None:
        if stamp > 1e8:
            self.rec.set_time("stamp", timestamp=stamp)
        else:  # simulated time starts near zero
            self.rec.set_time("stamp", duration=stamp)

    def handle(self, topic: str, msg) -> None:
        kind = type(msg).__name__
        if kind in IGNORED:
            return
        header = getattr(msg, "header", None)
        if header is not None:
            self._time(header.stamp)
        rec = self.rec
        if isinstance(msg, m.TFMessage):
            static = topic == "tf_static"
            if static or self._due("tf", kind):
                L.log_transforms(rec, "tf", msg, static=static, set_time=self._time)
            return
        spatial = {
            m.OccupancyGrid: L.log_occupancy_grid, m.Costmap: L.log_costmap, m.LaserScan: L.log_scan,
            m.PointCloud: L.log_cloud, m.Path: L.log_path, m.PolygonStamped: L.log_polygon,
            m.PoseStamped: L.log_pose,
        }
        fn = spatial.get(type(msg))
        if fn is not None:
            entity = "world/" + topic
            if self._due(entity, kind):
                fn(rec, entity, msg)
            return
        if isinstance(msg, m.DepthImage):
            if self._due("camera/" + topic, kind):
                L.log_depth_image(rec, "camera/depth", msg)
        elif isinstance(msg, m.Odometry):
            if self._due("odom", kind):
                self._trail.log(rec, "world/odom_trail", msg)
                rec.log("plots/odom/speed", rr.Scalars(msg.twist.linear.x))
        elif isinstance(msg, m.Twist):
            if self._due(topic, kind):
                rec.set_time("wall", timestamp=time.time())
                L.log_twist(rec, f"plots/{topic}", msg)
        elif isinstance(msg, m.Scalar):
            rec.log(f"plots/{topic}", rr.Scalars(msg.value))
        elif isinstance(msg, m.MoveBaseStatus):
            rec.log("plots/move_base/distance_to_goal", rr.Scalars(msg.distance_to_goal_m))
            self._text_on_change("log/move_base", f"{msg.state} {msg.goal_id}: {msg.reason or 'moving'}")
        elif isinstance(msg, m.NodeState):
            self._text_on_change(f"log/nodes/{msg.node}", f"{msg.node}: {msg.state} {msg.detail}".strip())
        elif isinstance(msg, m.GoalStatus):
            self._text_on_change(f"log/{topic}", f"goal {msg.goal_id} status {msg.status} {msg.text}")
        elif isinstance(msg, m.Collision):
            self._text_on_change("log/collisions", f"collision #{msg.count} at ({msg.x:.2f}, {msg.y:.2f})",
                                 level="WARN")
        elif isinstance(msg, m.Text):
            self._text_on_change(f"log/{topic}", msg.data)
        elif isinstance(msg, m.BatteryState):
            rec.log("plots/battery_voltage", rr.Scalars(msg.voltage))
        elif isinstance(msg, m.MotorState):
            self._text_on_change("log/motors", f"motors {'enabled' if msg.enabled else 'disabled'}")

    def _text_on_change(self, entity: str, text: str, level: str = "INFO") -> None:
        if self._last_text.get(entity) != text:
            self._last_text[entity] = text
            L.log_text(self.rec, entity, text, level)

    def close(self) -> None:
        try:
            self._sub.undeclare()
        except zenoh.ZError:
            pass
