"""Costmap node: feeds a LayeredCostmap from the bus and publishes it (costmap_2d::Costmap2DROS, thin).

Config (this node's YAML mapping): ``common`` and ``specific`` = paths of the ROS costmap files (relative
to the config file), optional ``name`` (global_costmap / local_costmap). Topics: ``<name>/costmap``,
``<name>/costmap/<layer>``, ``<name>/footprint``, ``<name>/status``; service ``<name>/clear``.
"""

from __future__ import annotations

import threading
from functools import partial
from pathlib import Path

from common.bus import Node
from common.messages import Empty, Header, LaserScan, OccupancyGrid, PointCloud, PolygonStamped, Text
from common.tf import TFListener
from master_side.costmap.footprint import transform_footprint
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.observation import scan_to_points
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.params import CostmapConfig, load_costmap_files
from master_side.costmap.static_layer import StaticLayer


class CostmapNode:
    def __init__(self, node: Node, cfg: CostmapConfig):
        self.node, self.cfg, self.name = node, cfg, cfg.name
        self.lcm = LayeredCostmap.from_config(cfg)
        self.lock = threading.Lock()
        self.pose = None  # last robot pose in the global frame
        self.tf = TFListener(node)
        self.frame = cfg.costmap.global_frame
        self.tol = cfg.costmap.transform_tolerance
        self.pub = node.publisher(f"{self.name}/costmap")
        self.layer_pubs = {x.name: node.publisher(f"{self.name}/costmap/{x.name}") for x in self.lcm.layers}
        self.fp_pub = node.publisher(f"{self.name}/footprint")
        self.status = node.publisher(f"{self.name}/status")
        self.subs = []
        for layer in self.lcm.layers:
            if isinstance(layer, ObstacleLayer):
                for src, buf in layer.buffers.items():
                    kind = LaserScan if buf.params.data_type == "LaserScan" else PointCloud
                    cb = partial(self._on_observation, layer, src)
                    topic = buf.params.topic.lstrip("/")
                    self.subs.append(node.subscribe(topic, kind, callback=cb, mode="queue"))
            elif isinstance(layer, StaticLayer):
                cb = partial(self._on_map, layer)
                topic = layer.params.map_topic.lstrip("/")
                self.subs.append(node.subscribe(topic, OccupancyGrid, callback=cb))
        node.service(f"{self.name}/clear", self._on_clear)
        c = cfg.costmap
        self.timers = [node.timer(1.0 / c.update_frequency, self.update)] if c.update_frequency > 0 else []
        if c.publish_frequency > 0:
            self.timers.append(node.timer(1.0 / c.publish_frequency, self.publish))

    def _say(self, text: str) -> None:
        self.status.publish(Text(Header(self.node.clock.now(), self.frame), text))

    def _on_observation(self, layer: ObstacleLayer, src: str, msg) -> None:
        params = layer.buffers[src].params
        try:
            data_tf = self.tf.buffer.lookup(self.frame, msg.header.frame_id, msg.header.stamp, self.tol)
            sensor_tf = data_tf if not params.sensor_frame else self.tf.buffer.lookup(
                self.frame, params.sensor_frame, msg.header.stamp, self.tol)
        except Exception as e:  # noqa: BLE001 - any TF failure: drop the reading and say why
            self._say(f"{src}: no transform {self.frame} <- {msg.header.frame_id}: {e}")
            return
        pts = scan_to_points(msg, params.inf_is_valid) if isinstance(msg, LaserScan) else msg.points
        origin = sensor_tf.transform.translation.as_array()
        with self.lock:
            layer.add_observation(src, data_tf.transform.apply(pts), origin, msg.header.stamp)

    def _on_map(self, layer: StaticLayer, msg: OccupancyGrid) -> None:
        to_global = None
        if self.lcm.rolling_window and msg.header.frame_id and msg.header.frame_id.lstrip("/") != self.frame:
            try:
                to_global = self.tf.buffer.lookup_pose2d(self.frame, msg.header.frame_id, 0.0, self.tol)
            except Exception as e:  # noqa: BLE001
                self._say(f"map: no transform {self.frame} <- {msg.header.frame_id}: {e}")
                return
        with self.lock:
            layer.set_map(msg, to_global)

    def update(self) -> None:
        now = self.node.clock.now()
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
        if stale:
            self._say(f"sensor data is late: {', '.join(stale)} (expected_update_rate)")

    def publish(self) -> None:
        header = Header(self.node.clock.now(), self.frame)
        with self.lock:
            self.pub.publish(self.lcm.master.to_message(header))
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
        self.tf.close()


def start(node: Node, cfg: dict, source: str) -> CostmapNode:
    base = Path(source).parent
    conf = load_costmap_files(base / cfg["common"], base / cfg["specific"], name=cfg.get("name"))
    return CostmapNode(node, conf)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("costmap", start)
