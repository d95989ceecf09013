"""The monitor: a Zenoh peer that logs one robot's topics to Rerun (our rviz).

It subscribes once to ``zenav/<robot>/**`` and dispatches on the decoded message type, so new
topics show up without configuration. Latched topics (map, tf_static) published before it started
are fetched from every publisher that announces them (liveliness), never from services.
Heavy streams are throttled per entity (``pacing.Throttle``, latest wins) so a long run keeps the
viewer's memory bounded. Time comes from the message stamps (``pacing.StampTimeline``). A robot pattern
(``*``) logs every matching robot side by side: one view per robot (its own throttle, timeline, ...),
its entities and TF frames under ``<robot>/`` (``loggers.Prefixed``). With a server history that drops
its oldest data (``--serve-web``), rarely logged entities such as a latched map are logged again while
unchanged (``keyframes.Keyframes``) so a page opened hours later still gets them.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from dataclasses import dataclass, field
from typing import Callable

import rerun as rr
import zenoh

from common import messages as m
from common.codec import DecodeError, decode
from common.latched_fetch import fetch_latched
from common.live_keys import LiveKey, live_key
from deploy.monitor import loggers as L
from deploy.monitor.events import STATUS_NAMES, TextEvents
from deploy.monitor.keyframes import Keyframes
from deploy.monitor.layout import blueprint  # noqa: F401 - re-exported for callers
from deploy.monitor.pacing import DEFAULT_RATES, StampTimeline, Throttle  # noqa: F401
from deploy.monitor.placement import Placement

log = logging.getLogger("zenav.monitor")

IGNORED = {"CameraInfo", "Empty"}
PLAN_COLORS = {"local_plan": (0, 200, 255)}


@dataclass
class MonitorStats:
    received: int = 0
    logged: int = 0
    throttled: int = 0
    malformed: int = 0
    errors: int = 0
    by_entity: dict = field(default_factory=dict)

    def line(self) -> str:
        return (f"received={self.received} logged={self.logged} throttled={self.throttled} "
                f"malformed={self.malformed} errors={self.errors}")


class Monitor(TextEvents):
    def __init__(self, session: zenoh.Session, robot: str, rec: rr.RecordingStream | L.Prefixed,
                 rates: dict[str, float] | None = None, flush_period: float = 0.05,
                 observers: list[Callable[[str, object], None]] | None = None,
                 base_frame: str = "base_link", subscribe: bool = True, keyframe_period: float = 0.0) -> None:
        self.robot, self.rec, self.session = robot, rec, session
        self.keyframes = Keyframes(keyframe_period)  # > 0 with a history that drops its oldest (--serve-web)
        self.base_frame = base_frame
        self._views: dict[str, Monitor] = {}  # robot pattern: robot name -> its Monitor
        self.observers = list(observers or [])  # e.g. the web page's state: every decoded message
        self.throttle = Throttle(rates)
        self.timeline = StampTimeline()
        self.stats = MonitorStats()
        self._last_text: dict[str, str] = {}
        self._trail = L.OdomTrail()
        self._odom_node: str | None = None  # the node publishing odom (the bus's attachment)
        self._odom_pid = 0  # ... and its process, as its agent last said (NodeState)
        self._placement = Placement()  # scans and clouds drawn with the transform at their stamp
        self._lock = threading.RLock()
        self._prefix = f"zenav/{robot}/"
        self._queried: set[str] = set()
        self._stop = threading.Event()
        if "*" not in robot:
            L.log_robot_marker(rec, "world/robot", base_frame)  # what the map view follows
        sel = robot if robot == "*" else robot.replace("*", "$*")  # 'pioneer*': a wildcard inside a chunk
        self._handles = [] if not subscribe else [
            session.declare_subscriber(f"zenav/{sel}/**", self._on_sample),
            session.liveliness().declare_subscriber(live_key(sel, "latched", "**"), self._on_publisher,
                                                    history=True),
        ]
        self._flusher = threading.Thread(target=self._flush_loop, args=(flush_period,), daemon=True,
                                         name="monitor-flush")
        if subscribe:
            self._flusher.start()

    def _view(self, robot: str) -> Monitor:
        """One robot's view (robot pattern): entities under ``robot/``, observers get ``robot/topic``."""
        with self._lock:
            if robot not in self._views:
                obs: list[Callable[..., None]] = [lambda t, msg, o=o: o(f"{robot}/{t}", msg) for o in self.observers]
                v = Monitor(self.session, robot, L.Prefixed(self.rec, robot), self.throttle.rates, observers=obs,
                            base_frame=self.base_frame, subscribe=False, keyframe_period=self.keyframes.period)
                v.stats, v._lock = self.stats, self._lock  # one count, one lock (the stream is shared)
                self._views[robot] = v
            return self._views[robot]

    # -- input -----------------------------------------------------------------------------------
    def _on_publisher(self, sample) -> None:
        """A publisher appeared: fetch its topic's latched message (no-op for unlatched ones)."""
        if sample.kind != zenoh.SampleKind.PUT:
            return
        k = LiveKey.parse(sample.key_expr)
        if k is None or not k.topic:
            return
        if "*" in self.robot:
            self._view(k.robot)._on_publisher(sample)
            return
        key = str(sample.key_expr)  # one query per publisher: several nodes may latch one topic (tf_static)
        if key in self._queried:
            return
        self._queried.add(key)
        # asked again until that publisher answers (a query right after its token may find no route yet)
        fetch_latched(self.session, self._prefix + k.topic, self._on_sample, retry=True,
                      closed=self._stop.is_set, expect=k.node)

    def _on_sample(self, sample) -> None:
        key = str(sample.key_expr)
        if "*" in self.robot:
            self._view(key.split("/")[1])._on_sample(sample)
            return
        if not key.startswith(self._prefix) or key.startswith(self._prefix + "srv/"):
            return
        topic = key[len(self._prefix):]
        try:
            msg = decode(sample.payload.to_bytes())
        except DecodeError as e:
            with self._lock:
                self.stats.malformed += 1
                if self.stats.malformed in (1, 10, 100) or self.stats.malformed % 1000 == 0:
                    log.warning("malformed payload on %s (#%d): %s", topic, self.stats.malformed, e)
            return
        with self._lock:
            self.stats.received += 1
            try:
                for observe in self.observers:
                    observe(topic, msg)
                att = sample.attachment  # the publishing node's name
                self.handle(topic, msg, att.to_bytes().decode(errors="replace") if att is not None else None)
            except Exception as e:  # noqa: BLE001 - a bad message or logging bug must not kill the monitor
                self.stats.errors += 1
                log.warning("could not log %s (%s): %s", topic, type(msg).__name__, e)

    # -- pacing ----------------------------------------------------------------------------------
    def _set_time(self, stamp: float | None) -> None:
        self.rec.reset_time()  # time is per thread: never inherit another message's stamp
        t = self.timeline.resolve(stamp)
        if t is not None:
            self.rec.set_time("stamp", **{t[0]: t[1]})

    def _submit(self, entity: str, topic: str, kind: str, stamp: float | None,
                fn: Callable[[], None]) -> None:
        self.keyframes.note(entity, kind, stamp, fn)
        if self.throttle.offer(entity, self.throttle.period(topic, kind), (stamp, fn)):
            self._emit(entity, stamp, fn)
        else:
            self.stats.throttled = self.throttle.dropped

    def _emit(self, entity: str, stamp: float | None, fn: Callable[[], None]) -> None:
        self._set_time(stamp)
        fn()
        self.stats.logged += 1
        self.stats.by_entity[entity] = self.stats.by_entity.get(entity, 0) + 1

    def _flush_loop(self, period: float) -> None:
        while not self._stop.wait(period):
            self.flush_pending()

    def flush_pending(self, flush_all: bool = False) -> None:
        with self._lock:
            for v in list(self._views.values()):
                v.flush_pending(flush_all)
            if self._views:
                self.stats.throttled = sum(v.throttle.dropped for v in self._views.values())
                return
            for submit in self._placement.due(flush_all):
                submit()
            for entity, (stamp, fn) in self.throttle.due(flush_all) + self.keyframes.due():
                try:
                    self._emit(entity, stamp, fn)
                except Exception as e:  # noqa: BLE001
                    self.stats.errors += 1
                    log.warning("could not log %s: %s", entity, e)
            self.stats.throttled = self.throttle.dropped

    # -- dispatch --------------------------------------------------------------------------------
    def handle(self, topic: str, msg, sender: str | None = None) -> None:
        """Log one message; ``sender``: the publishing node's name (the bus's attachment), if known."""
        kind = type(msg).__name__
        rec, sub = self.rec, self._submit
        if kind in IGNORED:
            return
        if isinstance(msg, m.Clock):  # simulated time advances even when nothing else is stamped
            self.timeline.resolve(msg.clock)
            return
        if isinstance(msg, m.TFMessage):
            static = topic == "tf_static"
            self._placement.remember(msg, static)
            for ts in msg.transforms:
                child = L.frame_name(ts.child_frame_id, "")
                if not child:
                    continue

                def fn(ts=ts, e=f"tf/{child}") -> None:
                    L.log_transform(rec, e, ts, static)

                if static:  # static data needs no time and is never throttled
                    self._emit(f"tf/{child}", None, fn)
                else:
                    sub(f"tf/{child}", topic, kind, ts.header.stamp, fn)
            return
        stamp = msg.header.stamp if hasattr(msg, "header") else None
        spatial: dict[type, Callable[..., None]] = {
            m.OccupancyGrid: L.log_occupancy_grid, m.Costmap: L.log_costmap,
            m.PolygonStamped: L.log_polygon, m.PoseStamped: L.log_pose,
        }
        sensors: dict[type, Callable[..., None]] = {m.LaserScan: L.log_scan, m.PointCloud: L.log_cloud}
        if type(msg) in sensors:  # placed with the transform at its stamp, once TF has it (placement.py)
            entity, log_it = "world/" + topic, sensors[type(msg)]

            def placed() -> None:
                log_it(rec, entity, msg, fixed=self._placement.at_stamp(msg.header))
            self._placement.place(entity, msg.header, lambda: sub(entity, topic, kind, stamp, placed))
        elif type(msg) in spatial:
            entity = "world/" + topic
            sub(entity, topic, kind, stamp, lambda: spatial[type(msg)](rec, entity, msg))
        elif isinstance(msg, m.Path) and topic.endswith("particlecloud"):  # AMCL's particles (x, y, yaw)
            sub("world/" + topic, topic, "ParticleCloud", stamp, lambda: L.log_particles(rec, "world/" + topic, msg))
        elif isinstance(msg, m.Path):
            color = PLAN_COLORS.get(topic.rsplit("/", 1)[-1], (40, 200, 40))
            sub("world/" + topic, topic, kind, stamp, lambda: L.log_path(rec, "world/" + topic, msg, color))
        elif isinstance(msg, m.DepthImage):
            entity = "camera/" + topic.removeprefix("camera/")
            sub(entity, topic, kind, stamp, lambda: L.log_depth_image(rec, entity, msg))
        elif isinstance(msg, m.Odometry):
            if topic != "odom":  # the simulator's ground_truth (map frame) or another source: no trail, no
                return            # speed plot (interleaved with odom's, they drew a smear metres off the path)
            self._odom_node = sender or self._odom_node

            def odom() -> None:
                self._trail.log(rec, "world/odom_trail", msg)
                rec.log("plots/odom/speed", rr.Scalars(msg.twist.linear.x))
            sub("world/odom_trail", topic, kind, stamp, odom)
        elif isinstance(msg, m.Twist):
            sub(f"plots/{topic}", topic, kind, None, lambda: L.log_twist(rec, f"plots/{topic}", msg))
        elif isinstance(msg, m.Scalar):
            entity = scalar_entity(topic)
            sub(entity, topic, kind, stamp, lambda: rec.log(entity, rr.Scalars(msg.value)))
        elif isinstance(msg, m.MoveBaseStatus):
            sub("plots/move_base/distance_to_goal", topic, kind, stamp,
                lambda: rec.log("plots/move_base/distance_to_goal", rr.Scalars(msg.distance_to_goal_m)))
            self._move_base_status(topic, msg)
        elif isinstance(msg, m.NodeState):
            self._node_state(topic, msg)
            if msg.node == self._odom_node and msg.pid:  # odometry's node in a new process: a new trail
                if self._odom_pid not in (0, msg.pid):
                    self._trail.restart()
                self._odom_pid = msg.pid
        elif isinstance(msg, m.CostmapSensors):
            self._sensors(topic, msg)
            for s in msg.sources:  # age of each source's last reading: gaps show as saw teeth
                entity = f"plots/sensors/{msg.costmap or topic}/{s.layer}/{s.source}"

                def age(e: str = entity, v: float = s.age_s) -> None:
                    rec.log(e, rr.Scalars(v))
                sub(entity, topic, kind, stamp, age)
        elif isinstance(msg, m.GoalStatus):
            name = STATUS_NAMES.get(msg.status, str(msg.status))
            self._text_on_change(f"log/{topic}", stamp, f"goal {msg.goal_id} {name} {msg.text}".strip())
        elif isinstance(msg, m.Collision):
            self._text_on_change("log/collisions", stamp,
                                 f"collision #{msg.count} at ({msg.x:.2f}, {msg.y:.2f})", level="WARN")
        elif isinstance(msg, m.Text):
            self._text_on_change(f"log/{topic}", stamp, msg.data)
        elif isinstance(msg, m.BatteryState):
            sub("plots/battery_voltage", topic, kind, stamp,
                lambda: rec.log("plots/battery_voltage", rr.Scalars(msg.voltage)))
        elif isinstance(msg, m.CollisionMonitorState):  # the robot's own safety: why it overrides cmd_vel
            sub("plots/collision_monitor/ratio", topic, kind, stamp,
                lambda: rec.log("plots/collision_monitor/ratio", rr.Scalars(msg.ratio)))
            text = msg.action + (f" ({msg.polygon})" if msg.polygon else "") + (f": {msg.reason}" if msg.reason else "")
            self._text_on_change("log/collision_monitor", stamp, text, "INFO" if msg.action in ("none", "") else "WARN",
                                 change=f"{msg.action}|{msg.polygon}")
        elif isinstance(msg, m.MotorState):
            self._text_on_change("log/motors", stamp, f"motors {'enabled' if msg.enabled else 'disabled'}")

    def close(self) -> None:
        """Stop receiving, then log what the throttle still held (the newest state of each entity)."""
        self._stop.set()
        for h in self._handles:
            with contextlib.suppress(zenoh.ZError):
                h.undeclare()
        self._flusher.join(2.0)
        self.flush_pending(flush_all=True)


def scalar_entity(topic: str) -> str:
    """``<node>/loop_time`` -> ``plots/loop_time/<node>``; any other Scalar topic -> ``plots/<topic>``."""
    if topic.endswith("/loop_time"):
        return "plots/loop_time/" + topic[: -len("/loop_time")]
    return "plots/" + topic
