"""Costmap node: feeds a LayeredCostmap from the bus and publishes it (costmap_2d::Costmap2DROS, thin).

Config (this node's YAML mapping): ``common`` and ``specific`` = paths of the ROS costmap files (relative
to the config file), optional ``name`` (global_costmap / local_costmap), optional ``sensor_grace`` (s,
default 1.0, see below). Topics: ``<name>/costmap``, ``<name>/costmap/<layer>``, ``<name>/footprint``,
``<name>/status`` (Text), ``<name>/sensors`` (CostmapSensors), ``<name>/costmap_trace`` (Scalar after
each master grid: its header, value = the newest observation stamp it includes; bench/loop.py); service
``<name>/clear``. The master grid goes out on ``<name>/costmap`` after every update (update_frequency):
move_base reads it over the bus, where ROS's move_base reads its costmap in process; publish_frequency
paces the per-layer and footprint topics (for display), and the master too when update_frequency is 0.

An observation source subscribes to its ``topic`` under the robot's key prefix (``front/scan`` and
``/front/scan`` are both ``zenav/<robot>/front/scan``). Sensor health (``costmap.health``), checked
every 0.2 s of wall time and published on ``<name>/sensors`` at 1 Hz and on every change, with one log
line per change of state (WARNING when a source turns late or silent, INFO when it recovers):

- late: ROS ``expected_update_rate`` (the longest gap between readings, s; 0: not checked), measured
  from when the last reading was buffered, as ROS does;
- silent (zenav's addition): a source that has delivered nothing since the costmap started, whatever
  its expected_update_rate, once ``sensor_grace`` seconds have passed — ROS would run blind, without
  a word, on a topic name nothing publishes. Messages that arrive but cannot be used (no transform)
  do not count as delivered; the status says why they were dropped.
"""

from __future__ import annotations

import threading
import time
from functools import partial
from pathlib import Path

from common.bus import Node
from common.clock import Timer, WallClock
from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Empty, Header, LaserScan, OccupancyGrid, PointCloud, PolygonStamped, Scalar, Text
from common.tf import TFListener
from master_side.costmap.footprint import transform_footprint
from master_side.costmap.health import GRACE_S, SensorWatch
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.observation import scan_to_points
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.params import CostmapConfig, check_costmap_node, load_costmap_files
from master_side.costmap.static_layer import StaticLayer

SENSORS_CHECK_S = 0.2  # wall seconds between sensor health checks
SENSORS_PUBLISH_S = 1.0  # <name>/sensors at least this often


class CostmapNode:
    def __init__(self, node: Node, cfg: CostmapConfig, sensor_grace: float = GRACE_S):
        self.node, self.cfg, self.name = node, cfg, cfg.name
        self.watch = SensorWatch(self.name, time.monotonic(), sensor_grace)
        self.lcm = LayeredCostmap.from_config(cfg)
        self.lock = threading.Lock()
        self.pose: Pose2D | None = None  # last robot pose in the global frame
        self._updated: float | None = None  # time of the last update
        self._newest_obs = 0.0  # newest observation stamp buffered (traceability: <name>/costmap_trace)
        self.tf = TFListener(node)
        self.frame = cfg.costmap.global_frame
        self.tol = cfg.costmap.transform_tolerance
        self.pub = node.publisher(f"{self.name}/costmap")
        self.layer_pubs = {x.name: node.publisher(f"{self.name}/costmap/{x.name}") for x in self.lcm.layers}
        self.fp_pub = node.publisher(f"{self.name}/footprint")
        self.status = node.publisher(f"{self.name}/status")
        self.sensors_pub = node.publisher(f"{self.name}/sensors")
        self.trace_pub = node.publisher(f"{self.name}/costmap_trace")
        self.subs = []
        self.timers: list = []  # set below; _on_observation may run before that (it kicks the update timer)
        self.source_subs = {}  # (layer, source) -> Subscription
        self._map_frames: dict[int, str] = {}  # id(static layer) -> its map's frame (rolling, another frame)
        self._unplaced: set[int] = set()  # those not yet placed by a transform
        for layer in self.lcm.layers:
            if isinstance(layer, ObstacleLayer):
                for src, buf in layer.buffers.items():
                    kind = LaserScan if buf.params.data_type == "LaserScan" else PointCloud
                    cb = partial(self._on_observation, layer, src)
                    topic = (buf.params.topic or src).strip("/")  # under zenav/<robot>/, as ROS's global names
                    sub = node.subscribe(topic, kind, callback=cb, mode="queue")
                    self.subs.append(sub)
                    self.source_subs[(layer.name, src)] = sub
                    if layer.enabled:  # as ROS isCurrent: a disabled layer's sources do not count
                        self.watch.add(layer.name, buf, kind.__name__)
            elif isinstance(layer, StaticLayer):
                cb = partial(self._on_map, layer)
                topic = layer.params.map_topic.lstrip("/")
                self.subs.append(node.subscribe(topic, OccupancyGrid, callback=cb))
        node.service(f"{self.name}/clear", self._on_clear)
        c = cfg.costmap
        self.timers = [node.timer(1.0 / c.update_frequency, self.update, on_data=c.update_on_observation)
                       ] if c.update_frequency > 0 else []
        if c.publish_frequency > 0:
            self.timers.append(node.timer(1.0 / c.publish_frequency, self.publish))
        self._sensors_sent = float("-inf")
        # wall time: reports even when a simulated clock does not run; with no sources too (readers then
        # know this costmap has nothing to wait for)
        self.timers.append(Timer(WallClock(), SENSORS_CHECK_S, self.check_sensors, name=f"sensors:{self.name}",
                                 on_error=lambda e: node.log.error("sensor check failed: %s", e)))

    def _say(self, text: str) -> None:
        self.status.publish(Text(Header(self.node.clock.now(), self.frame), text))

    def _on_observation(self, layer: ObstacleLayer, src: str, msg) -> None:
        buf = layer.buffers[src]
        params = buf.params
        with self.lock:
            self.watch.received(layer.name, src)
        try:
            data_tf = self.tf.buffer.lookup(self.frame, msg.header.frame_id, msg.header.stamp, self.tol)
            sensor_tf = data_tf if not params.sensor_frame else self.tf.buffer.lookup(
                self.frame, params.sensor_frame, msg.header.stamp, self.tol)
        except Exception as e:  # noqa: BLE001 - any TF failure: drop the reading and say why
            why = f"no transform {self.frame} <- {params.sensor_frame or msg.header.frame_id}: {e}"
            with self.lock:
                self.watch.dropped(layer.name, src, why)
            self._say(f"{src}: {why}")
            return
        pts = scan_to_points(msg, params.inf_is_valid) if isinstance(msg, LaserScan) else msg.points
        origin = sensor_tf.transform.translation.as_array()
        with self.lock:  # ROS: last_updated is when the reading was buffered (is_current)
            buf.add(data_tf.transform.apply(pts), origin, msg.header.stamp, received=self.node.clock.now())
            self._newest_obs = max(self._newest_obs, msg.header.stamp)
            self.watch.used(layer.name, src)
        if self.timers and self.cfg.costmap.update_on_observation:
            self.timers[0].kick()  # only an on_data timer reacts

    def check_sensors(self) -> None:
        """Sensor health: log each change of state, publish ``<name>/sensors`` on a change and at 1 Hz."""
        mono = time.monotonic()
        now = self.node.clock.now()
        with self.lock:
            for key, sub in self.source_subs.items():
                self.watch.malformed(*key, sub.malformed)
            msg, events = self.watch.report(Header(now, self.frame), now, mono)
        for level, text in events:
            (self.node.log.warning if level == "WARNING" else self.node.log.info)("%s", text)
        if events or mono - self._sensors_sent >= SENSORS_PUBLISH_S - 1e-3:
            self._sensors_sent = mono
            self.sensors_pub.publish(msg)

    def _on_map(self, layer: StaticLayer, msg: OccupancyGrid) -> None:
        """Keep the map (it is latched and comes once); a rolling costmap in another frame places it by
        the current transform in ``_place_maps``, before every update."""
        frame = (msg.header.frame_id or "").lstrip("/")
        with self.lock:
            if not layer.set_map(msg):
                return
            if self.lcm.rolling_window and frame and frame != self.frame:
                self._map_frames[id(layer)] = frame
                self._unplaced.add(id(layer))
        self._place_maps()

    def _place_maps(self) -> None:
        """A rolling costmap's static layers follow their map frame (map -> odom changes with localisation),
        as ROS's StaticLayer looks the transform up in every update. No wait: a missing transform keeps the
        last placement (and, before the first one, holds the update: see ``update``)."""
        for layer in self.lcm.layers:
            frame = self._map_frames.get(id(layer), "")
            if not (isinstance(layer, StaticLayer) and frame):
                continue
            try:
                pose = self.tf.buffer.lookup_pose2d(self.frame, frame, 0.0, 0.0)
            except Exception:  # noqa: BLE001 - said by update() while it matters (never placed)
                continue
            with self.lock:
                layer.place(pose)
                self._unplaced.discard(id(layer))

    def _missing_maps(self) -> list[str]:
        """Map topics of enabled static layers that have no map yet. ROS's StaticLayer blocks the
        costmap's start until its map comes, so move_base never plans on a costmap without it; this
        costmap neither updates nor publishes its master grid until then."""
        return [x.params.map_topic for x in self.lcm.layers
                if isinstance(x, StaticLayer) and x.enabled and x.map is None]

    def update(self) -> None:
        now = self.node.clock.now()
        if missing := self._missing_maps():
            self._say(f"not updating: waiting for the map on {', '.join(missing)}")
            return
        self._place_maps()
        if self._unplaced:
            frames = sorted({self._map_frames[i] for i in self._unplaced})
            self._say(f"not updating: no transform {self.frame} <- {', '.join(frames)} to place the map yet")
            return
        base = self.cfg.costmap.robot_base_frame
        try:
            tf = self.tf.buffer.lookup(self.frame, base, 0.0, self.tol)
        except Exception as e:  # noqa: BLE001
            self._say(f"not updating: no transform {self.frame} <- {base}: {e}")
            return
        if tf.header.stamp > 0 and now - tf.header.stamp > self.tol:  # stamp 0: an all-static chain
            self._say(f"not updating: transform {self.frame} <- {base} is {now - tf.header.stamp:.2f} s old "
                      f"(transform_tolerance {self.tol} s)")
            return
        self.pose = tf.transform.to_pose2d()
        with self.lock:
            self.lcm.update_map(self.pose)
            stale = self.lcm.stale_sources(now)
            # move_base reads this costmap over the bus: each update goes out at once (ROS's move_base
            # reads its in-process costmap), publish_frequency paces only the display topics
            self._updated = now
            newest = self._newest_obs
            self.pub.publish(self.lcm.master.to_message(Header(now, self.frame), unknown_as=self.cfg.costmap.unseen_as))
        self.trace_pub.publish(Scalar(Header(now, self.frame), newest))
        if stale:
            self._say(f"sensor data is late: {', '.join(stale)} (expected_update_rate)")

    def publish(self) -> None:
        # the layers as of the last update carry its stamp, so they pair with that master grid
        header = Header(self._updated if self._updated is not None else self.node.clock.now(), self.frame)
        with self.lock:
            if self.cfg.costmap.update_frequency <= 0 and not self._missing_maps():
                self.pub.publish(self.lcm.master.to_message(header, unknown_as=self.cfg.costmap.unseen_as))
            for layer in self.lcm.layers:
                grid = layer.grid()
                if grid is not None:
                    self.layer_pubs[layer.name].publish(grid.to_message(header, layer.name))
            if self.pose is not None:
                polygon = transform_footprint(self.lcm.footprint, self.pose).astype("float32")
                self.fp_pub.publish(PolygonStamped(header, polygon))

    def _on_clear(self, req) -> Empty:
        """``<name>/clear``: a Scalar request keeps obstacles within a square of that side around the
        robot (move_base's conservative / aggressive reset); any other request clears everything."""
        distance = getattr(req, "value", 0.0)
        with self.lock:
            if distance > 0 and self.pose is not None:
                self.lcm.clear_outside(self.pose, distance)
            else:
                self.lcm.reset()
        return Empty()

    def reset(self) -> None:
        """Forget all obstacles (move_base recovery / ``<name>/clear``)."""
        with self.lock:
            self.lcm.reset()

    def close(self) -> None:
        for t in self.timers:
            t.cancel()
        for t in self.timers:
            t.join(1.0)
        self.tf.close()


def start(node: Node, cfg: dict, source: str) -> CostmapNode:
    base = Path(source).parent
    conf = load_costmap_files(base / cfg["common"], base / cfg["specific"], name=cfg.get("name"))
    grace = cfg.get("sensor_grace", GRACE_S)
    if isinstance(grace, bool) or not isinstance(grace, (int, float)) or not 0 <= grace <= 3600:
        raise ConfigError(source, "sensor_grace", f"{grace!r}: seconds in [0, 3600]")
    return CostmapNode(node, conf, float(grace))


check = check_costmap_node  # the agents' parameter check before anything starts (common.node_check)

if __name__ == "__main__":
    from common.runner import node_main

    node_main("costmap", start)
