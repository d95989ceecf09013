"""A synthetic robot on the bus: every topic the monitor displays, with a known, consistent geometry.

    python -m testkit.synthetic_monitor [--duration S] [--sim-time]     # then: zenav monitor

A 10 x 8 m room with a box, a robot driving a circle in it, TF ``map -> odom -> base_link -> laser``
(the laser mounted backwards, yaw pi) and ``base_link -> camera_link``, a ray-cast laser scan, map,
global / local costmaps with obstacle and inflation layers, plans, footprint, goal, odometry,
cmd_vel, a depth image and cloud, move_base status, loop times, node states and the local costmap's
sensor status. Used by the monitor's
tests and the web-viewer check; handy to try the monitor without a robot.
"""

from __future__ import annotations

import argparse
import math
import threading
import time

import numpy as np
from scipy.ndimage import distance_transform_edt

from common import messages as m
from common.bus import Node
from common.geometry import Pose2D, Quaternion, Transform, Vector3

ROOM = (0.0, 0.0, 10.0, 8.0)  # x0, y0, x1, y1 (map frame)
BOX = (6.0, 3.0, 7.0, 4.0)
RES, MAP_ORIGIN, MAP_SHAPE = 0.05, Pose2D(-1.0, -1.0, 0.0), (200, 240)  # (rows, cols)
MAP_TO_ODOM = Pose2D(0.5, -0.3, 0.15)
LASER_IN_BASE = Transform(Vector3(0.2, 0.0, 0.25), Quaternion.from_yaw(math.pi))
CAMERA_IN_BASE = Transform(Vector3(0.1, 0.0, 0.4), Quaternion.from_yaw(0.0))
GOAL = Pose2D(8.0, 6.0, 0.5)
SCAN_N, SCAN_GAP = 360, range(100, 120)  # rays SCAN_GAP return nothing (+inf)
FOOTPRINT = np.array([[0.3, 0.2], [0.3, -0.2], [-0.25, -0.2], [-0.25, 0.2]])


def _segments() -> np.ndarray:
    out = []
    for x0, y0, x1, y1 in (ROOM, BOX):
        c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        out += [(*c[i], *c[(i + 1) % 4]) for i in range(4)]
    return np.array(out)


SEGMENTS = _segments()


def base_in_map(t: float) -> Pose2D:
    """The robot's true pose at ``t`` seconds: a circle of radius 1.5 m around (3.5, 4)."""
    a = 0.25 * t
    return Pose2D(3.5 + 1.5 * math.cos(a), 4.0 + 1.5 * math.sin(a), a + math.pi / 2)


def raycast(origin: np.ndarray, angles: np.ndarray, max_range: float) -> np.ndarray:
    """Distance along each ray (map frame angles) to the nearest wall segment (+inf if none)."""
    d = np.column_stack((np.cos(angles), np.sin(angles)))[:, None, :]  # (R, 1, 2)
    a, e = SEGMENTS[None, :, :2], SEGMENTS[None, :, 2:] - SEGMENTS[None, :, :2]  # (1, S, 2)
    w = a - origin
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
        u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / den
    t = np.where((np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1), t, np.inf)
    r = t.min(axis=1)
    return np.where(r <= max_range, r, np.inf)


def occupancy() -> np.ndarray:
    """The room as an OccupancyGrid array (row 0 at the origin's y): 100 walls/box, 0 inside, -1 outside."""
    rows, cols = MAP_SHAPE
    x = MAP_ORIGIN.x + (np.arange(cols) + 0.5) * RES
    y = MAP_ORIGIN.y + (np.arange(rows) + 0.5) * RES
    X, Y = np.meshgrid(x, y)
    x0, y0, x1, y1 = ROOM
    inside = (x0 <= X) & (x1 >= X) & (y0 <= Y) & (y1 >= Y)
    grid = np.where(inside, 0, -1).astype(np.int8)
    near_wall = np.minimum(np.abs(X - x0), np.abs(X - x1)) < RES
    near_wall |= np.minimum(np.abs(Y - y0), np.abs(Y - y1)) < RES
    wall = inside & near_wall
    bx0, by0, bx1, by1 = BOX
    box = (bx0 - RES <= X) & (bx1 + RES >= X) & (by0 - RES <= Y) & (by1 + RES >= Y)
    grid[wall | box] = 100
    return grid


def inflate(occ: np.ndarray, inscribed: float = 0.25, radius: float = 0.6) -> tuple[np.ndarray, np.ndarray]:
    """(obstacle layer, inflation layer) costmap arrays from an occupancy array (costmap_2d values)."""
    lethal = occ >= 100
    obstacle = np.where(lethal, 254, np.where(occ < 0, 255, 0)).astype(np.uint8)
    dist = distance_transform_edt(~lethal) * RES
    cost = np.where(dist <= inscribed, 253, 252 * np.exp(-3.0 * (dist - inscribed)))
    inflation = np.where(dist <= radius, cost, 0).astype(np.uint8)
    inflation[lethal] = 254
    return obstacle, inflation


def _ts(stamp: float, parent: str, child: str, tf: Transform) -> m.TransformStamped:
    return m.TransformStamped(m.Header(stamp, parent), child, tf)


class SyntheticRobot:
    """Publishes the scene from a thread: fast topics at ``rate_hz``, heavy ones at ``heavy_hz``,
    costmaps at ``costmap_hz`` (default heavy_hz). ``sim_time``: stamps count from 0 (and ``clock``)."""

    def __init__(self, node: Node, sim_time: bool = False, rate_hz: float = 10.0, heavy_hz: float = 2.0,
                 costmap_hz: float | None = None) -> None:
        self.node, self.sim_time = node, sim_time
        self.rate_hz, self.heavy_hz, self.costmap_hz = rate_hz, heavy_hz, costmap_hz or heavy_hz
        self.occ = occupancy()
        self.obstacle, self.inflation = inflate(self.occ)
        self.master = np.maximum(self.obstacle, self.inflation)
        self.pubs: dict[str, object] = {}
        self.t0 = time.time()
        self.ticks = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="synthetic")

    def pub(self, topic: str, msg, latched: bool = False) -> None:
        if topic not in self.pubs:
            self.pubs[topic] = self.node.publisher(topic, latched=latched)
        self.pubs[topic].publish(msg)

    def stamp(self, t: float) -> float:
        return t if self.sim_time else self.t0 + t

    def start(self) -> SyntheticRobot:
        s = self.stamp(0.0)
        self.pub("map", m.OccupancyGrid(m.Header(s, "map"), RES, MAP_ORIGIN, self.occ), latched=True)
        self.pub("tf_static", m.TFMessage((_ts(s, "base_link", "laser", LASER_IN_BASE),
                                           _ts(s, "base_link", "camera_link", CAMERA_IN_BASE))), latched=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        period, next_heavy, next_cost = 1.0 / self.rate_hz, 0.0, 0.0
        start = time.monotonic()
        while not self._stop.is_set():
            t = time.monotonic() - start
            if t >= next_cost:
                self.publish_costmaps(t)
                next_cost = t + 1.0 / self.costmap_hz
            if t >= next_heavy:
                self.publish_heavy(t)
                next_heavy = t + 1.0 / self.heavy_hz
            if self.ticks <= t * self.rate_hz:
                self.publish_fast(t)
                self.ticks += 1
            self._stop.wait(min(period, 1.0 / self.costmap_hz) / 2)

    def publish_fast(self, t: float) -> None:
        s, robot = self.stamp(t), base_in_map(t)
        odom_base = MAP_TO_ODOM.inverse().compose(robot)
        if self.sim_time:
            self.pub("clock", m.Clock(s))
        self.pub("tf", m.TFMessage((_ts(s, "map", "odom", MAP_TO_ODOM.to_transform()),
                                    _ts(s, "odom", "base_link", odom_base.to_transform()))))
        self.pub("scan", self.scan(s, robot))
        self.pub("odom", m.Odometry(m.Header(s, "odom"), "base_link", odom_base.to_transform(),
                                    m.Twist.planar(0.375, 0.25)))
        # the simulator's evaluation topic: the same motion in the map frame, a different Odometry stream
        self.pub("ground_truth", m.Odometry(m.Header(s, "map"), "base_link", robot.to_transform(),
                                            m.Twist.planar(0.375, 0.25)))
        self.pub("cmd_vel", m.Twist.planar(0.375, 0.25 + 0.05 * math.sin(t)))
        phase = int(t // 2) % 3
        self.pub("move_base/status", m.MoveBaseStatus(
            m.Header(s, "map"), goal_id="g1", status=1, state=("PLANNING", "CONTROLLING", "CLEARING")[phase],
            reason="blocked for %.1f s" % (t % 2) if phase == 2 else "",
            goal=m.PoseStamped(m.Header(s, "map"), GOAL.to_transform()),
            distance_to_goal_m=robot.distance(GOAL)))
        self.pub("move_base/loop_time", m.Scalar(m.Header(s), 0.02 + 0.005 * math.sin(3 * t)))
        self.pub("local_costmap/loop_time", m.Scalar(m.Header(s), 0.01 + 0.003 * math.cos(2 * t)))
        state = "STARTING" if t < 1.0 else "RUNNING"
        self.pub("agent/synth/state", m.NodeState(m.Header(s), node="move_base", state=state, pid=1))

    def scan(self, s: float, robot: Pose2D) -> m.LaserScan:
        laser = robot.to_transform().compose(LASER_IN_BASE).to_pose2d()
        inc = 2 * math.pi / SCAN_N
        angles = -math.pi + inc * np.arange(SCAN_N)
        r = raycast(np.array([laser.x, laser.y]), angles + laser.theta, 20.0).astype(np.float32)
        r[list(SCAN_GAP)] = np.inf
        return m.LaserScan(m.Header(s, "laser"), -math.pi, -math.pi + inc * (SCAN_N - 1), inc, 0.0, 0.1,
                           0.05, 20.0, r)

    def publish_costmaps(self, t: float) -> None:
        s, robot = self.stamp(t), base_in_map(t)
        self.pub("global_costmap/costmap", m.Costmap(m.Header(s, "map"), RES, MAP_ORIGIN, self.master))
        # Local: a 4 x 4 m window around the robot in the odom frame, sampled from the global grid.
        odom_robot = MAP_TO_ODOM.inverse().compose(robot)
        origin = Pose2D(round(odom_robot.x / RES) * RES - 2.0, round(odom_robot.y / RES) * RES - 2.0, 0.0)
        c = (np.arange(80) + 0.5) * RES
        X, Y = np.meshgrid(origin.x + c, origin.y + c)
        pts = MAP_TO_ODOM.apply(np.column_stack((X.ravel(), Y.ravel())))
        col = np.floor((pts[:, 0] - MAP_ORIGIN.x) / RES).astype(int).clip(0, MAP_SHAPE[1] - 1)
        row = np.floor((pts[:, 1] - MAP_ORIGIN.y) / RES).astype(int).clip(0, MAP_SHAPE[0] - 1)
        h = m.Header(s, "odom")
        layers = (("", self.master), ("obstacle_layer", self.obstacle), ("inflation_layer", self.inflation))
        for name, grid in layers:
            local = np.ascontiguousarray(grid[row, col].reshape(80, 80))
            topic = "local_costmap/costmap" + (f"/{name}" if name else "")
            self.pub(topic, m.Costmap(h, RES, origin, local, name))
        fp = odom_robot.apply(FOOTPRINT).astype(np.float32)
        self.pub("local_costmap/footprint", m.PolygonStamped(h, fp))

    def publish_heavy(self, t: float) -> None:
        s, robot = self.stamp(t), base_in_map(t)
        k = np.linspace(0, 1, 50)[:, None]
        plan = np.hstack((robot.x + k * (GOAL.x - robot.x), robot.y + k * (GOAL.y - robot.y),
                          np.zeros((50, 1))))
        self.pub("move_base/global_plan", m.Path(m.Header(s, "map"), plan))
        local = plan[:10].copy()
        local[:, :2] = MAP_TO_ODOM.inverse().apply(local[:, :2])
        self.pub("move_base/local_plan", m.Path(m.Header(s, "odom"), local))
        self.pub("move_base/current_goal", m.PoseStamped(m.Header(s, "map"), GOAL.to_transform()))
        yy, zz = np.meshgrid(np.linspace(-0.6, 0.6, 40), np.linspace(-0.4, 0.2, 20))
        cloud = np.column_stack((np.full(yy.size, 1.5), yy.ravel(), zz.ravel())).astype(np.float32)
        self.pub("camera/depth/points", m.PointCloud(m.Header(s, "camera_link"), cloud))
        v, u = np.mgrid[0:60, 0:80]
        depth = (1.0 + 3.0 * u / 80 + 0.5 * np.sin(v / 6.0 + t)).astype(np.float32)
        self.pub("camera/depth/image", m.DepthImage(m.Header(s, "camera_link"), depth))
        src = m.ObservationSourceStatus("laser_scan_sensor", "obstacle_layer", "scan", "LaserScan", True,
                                        int(t * self.rate_hz), 1.0 / self.rate_hz, 0.0, "ok",
                                        "source 'laser_scan_sensor' on topic 'scan' (LaserScan): ok")
        self.pub("local_costmap/sensors", m.CostmapSensors(m.Header(s, "odom"), "local_costmap", (src,)))

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=0.0, help="seconds to run (0 = until Ctrl-C)")
    ap.add_argument("--sim-time", action="store_true",
                    help="stamps from 0 s (simulated time) and a clock topic")
    ap.add_argument("--costmap-hz", type=float, default=None, help="costmap publish rate (default 2 Hz)")
    args = ap.parse_args(argv)
    node = Node("synthetic")
    robot = SyntheticRobot(node, sim_time=args.sim_time, costmap_hz=args.costmap_hz).start()
    print(f"synthetic robot '{node.robot}' publishing; Ctrl-C to stop", flush=True)
    try:
        end = time.monotonic() + args.duration if args.duration > 0 else math.inf
        while time.monotonic() < end:
            time.sleep(min(0.5, max(0.0, end - time.monotonic())))
    except KeyboardInterrupt:
        pass
    finally:
        robot.close()
        node.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
