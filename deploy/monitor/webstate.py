"""What the web page's own map panel shows, kept from the messages the monitor already receives.

Pure (no rerun / zenoh / http): the monitor feeds every decoded message to ``WebState.observe`` and the
HTTP server reads ``snapshot()`` (JSON-ready) and ``map_payload()``. Poses are brought into the map frame
through a small 2D TF cache fed by ``tf`` / ``tf_static`` (the robot is ``base_frame`` in ``map_frame``).
"""

from __future__ import annotations

import base64
import math
import threading
import time

import numpy as np

from common import messages as m
from common.geometry import Pose2D

MAX_PARTICLES = 600  # drawn on the page (every k-th particle beyond that)
MAX_PLAN_POINTS = 400


def _frame(fid: str, default: str = "map") -> str:
    return fid.strip().lstrip("/") or default


def _pose(p: Pose2D | None) -> dict | None:
    return None if p is None else {"x": round(p.x, 4), "y": round(p.y, 4), "yaw": round(p.theta, 4)}


def covariance_ellipse(xy: np.ndarray, weights: np.ndarray | None = None, sigmas: float = 2.0):
    """(centre (2,), semi-axes (2,), angle) of the ``sigmas`` ellipse of 2D points; None below 2 points."""
    if len(xy) < 2:
        return None
    w = np.full(len(xy), 1.0 / len(xy)) if weights is None else weights / weights.sum()
    c = (xy * w[:, None]).sum(axis=0)
    d = xy - c
    cov = (d * w[:, None]).T @ d
    vals, vecs = np.linalg.eigh(cov)
    vals = np.maximum(vals, 0.0)
    return c, sigmas * np.sqrt(vals[::-1]), math.atan2(vecs[1, 1], vecs[0, 1])


class Tf2D:
    """child frame -> (parent frame, Pose2D of the child in the parent); latest value wins."""

    def __init__(self) -> None:
        self.edges: dict[str, tuple[str, Pose2D]] = {}

    def add(self, msg: m.TFMessage) -> None:
        for ts in msg.transforms:
            self.edges[_frame(ts.child_frame_id, "")] = (_frame(ts.header.frame_id), ts.transform.to_pose2d())

    def lookup(self, target: str, source: str) -> Pose2D | None:
        """Pose of ``source`` in ``target`` (``source`` must be below ``target`` in the tree)."""
        pose, frame, hops = Pose2D(), source, 0
        while frame != target:
            edge = self.edges.get(frame)
            if edge is None or hops > 32:
                return None
            frame, pose, hops = edge[0], edge[1].compose(pose), hops + 1
        return pose

    def to_map(self, frame: str, target: str, pts: np.ndarray) -> np.ndarray | None:
        """(N, >=2) points of ``frame`` in ``target`` (x, y only)."""
        frame = _frame(frame, target)
        if frame == target:
            return pts[:, :2]
        t = self.lookup(target, frame)
        if t is None:
            return None
        c, s = math.cos(t.theta), math.sin(t.theta)
        return np.column_stack((t.x + c * pts[:, 0] - s * pts[:, 1], t.y + s * pts[:, 0] + c * pts[:, 1]))


class WebState:
    def __init__(self, robot: str, map_frame: str = "map", base_frame: str = "base_link") -> None:
        self.robot, self.map_frame, self.base_frame = robot, map_frame, base_frame
        self.lock = threading.Lock()
        self.tf = Tf2D()
        self.map: m.OccupancyGrid | None = None
        self.map_version = 0
        self.mission: dict | None = None  # the page's waypoint queue as it is driven (commands.py)
        self.last_data: float | None = None  # monotonic time of the robot's last message (not the map)
        self._map_payload: dict | None = None
        self.move_base: m.MoveBaseStatus | None = None
        self.safety: m.CollisionMonitorState | None = None
        self.amcl: Pose2D | None = None
        self.particles: np.ndarray = np.zeros((0, 3))
        self.plan: list = []
        self.footprint: list = []
        self.goal: Pose2D | None = None
        self.events: list[str] = []  # what the page did (goal sent, ...), newest last

    # -- input (the monitor's thread) --------------------------------------------------------------
    def observe(self, topic: str, msg) -> None:
        with self.lock:
            if topic != "map":  # the latched map comes again on a query: not a sign of a live robot
                self.last_data = time.monotonic()
            if isinstance(msg, m.TFMessage):
                self.tf.add(msg)
            elif isinstance(msg, m.OccupancyGrid) and topic.rsplit("/", 1)[-1] == "map":
                self.map, self._map_payload = msg, None
                self.map_version += 1
            elif isinstance(msg, m.MoveBaseStatus):
                self.move_base = msg
            elif isinstance(msg, m.CollisionMonitorState):
                self.safety = msg
            elif isinstance(msg, m.PoseStamped) and topic == "amcl_pose":
                self.amcl = msg.pose.to_pose2d()
            elif isinstance(msg, m.PoseStamped) and topic.endswith("goal") and "simple" in topic:
                self.goal = msg.pose.to_pose2d()
            elif isinstance(msg, m.Path) and topic.endswith("particlecloud"):
                self.particles = np.asarray(msg.poses, float)
            elif isinstance(msg, m.Path) and topic.endswith("global_plan"):
                pts = self.tf.to_map(msg.header.frame_id, self.map_frame, np.asarray(msg.poses, float))
                self.plan = [] if pts is None else pts[:: max(1, len(pts) // MAX_PLAN_POINTS)].round(3).tolist()
            elif isinstance(msg, m.PolygonStamped) and topic.endswith("global_costmap/footprint"):
                pts = self.tf.to_map(msg.header.frame_id, self.map_frame, np.asarray(msg.points, float))
                self.footprint = [] if pts is None else pts.round(3).tolist()

    def mission_line(self, text: str, active: bool = True, waypoints: list | None = None) -> None:
        """The waypoint queue's progress (a line of deploy/stack/missions.py's), shown in the page's bar."""
        with self.lock:
            old = self.mission or {}
            self.mission = {"line": text, "active": active,
                            "waypoints": waypoints if waypoints is not None else old.get("waypoints", [])}

    def note(self, text: str) -> None:
        with self.lock:
            self.events = (self.events + [text])[-5:]

    # -- output (the HTTP threads) -----------------------------------------------------------------
    def why_not_moving(self) -> str:
        mb, s = self.move_base, self.safety
        parts = []
        if mb is not None and mb.reason:
            parts.append(mb.reason)
        idle = mb is None or not mb.state or mb.state.upper() == "IDLE"
        if s is not None and s.action not in ("none", "") and not (idle and s.action == "stale_cmd"):
            parts.append(f"robot safety: {s.action}" + (f" ({s.reason})" if s.reason else ""))
        return "; ".join(parts)

    def snapshot(self) -> dict:
        from deploy.monitor.events import STATUS_NAMES

        with self.lock:
            mb = self.move_base
            parts = self.particles[:: max(1, len(self.particles) // MAX_PARTICLES)]
            ell = covariance_ellipse(self.particles[:, :2]) if len(self.particles) > 1 else None
            goal = self.goal
            if mb is not None and mb.goal_id and mb.goal.header.frame_id:
                goal = mb.goal.pose.to_pose2d()
            return {
                "robot": self.robot, "frame": self.map_frame, "map_version": self.map_version,
                "pose": _pose(self.tf.lookup(self.map_frame, self.base_frame)),
                "amcl": _pose(self.amcl),
                "particles": parts.round(3).tolist(),
                "ellipse": None if ell is None else {"x": float(ell[0][0]), "y": float(ell[0][1]),
                                                      "a": float(ell[1][0]), "b": float(ell[1][1]),
                                                      "angle": float(ell[2])},
                "plan": self.plan, "footprint": self.footprint, "goal": _pose(goal),
                "move_base": None if mb is None else {
                    "state": mb.state, "status": STATUS_NAMES.get(mb.status, str(mb.status)),
                    "goal_id": mb.goal_id, "distance": round(mb.distance_to_goal_m, 3)},
                "why": self.why_not_moving(), "events": list(self.events), "mission": self.mission,
                "data_age_s": None if self.last_data is None else round(time.monotonic() - self.last_data, 1),
            }

    def map_payload(self) -> dict | None:
        """The map as grey levels in image order (row 0 = the top = the highest y, as in a PGM file; the ROS
        grid's row 0 is the lowest y): base64 of uint8 h*w plus its geometry. The page draws the rows as
        they come, so what it shows cannot be mirrored by the drawing code."""
        with self.lock:
            g = self.map
            if g is None:
                return None
            if self._map_payload is None:
                from deploy.monitor.loggers import known_part

                part, origin = known_part(np.asarray(g.data), g.origin, g.resolution)  # SLAM's: mostly unknown
                d = part.astype(np.int16)
                grey = np.where(d < 0, 128, 254 - np.clip(d, 0, 100) * 254 // 100).astype(np.uint8)[::-1]
                self._map_payload = {
                    "version": self.map_version, "width": int(part.shape[1]), "height": int(part.shape[0]),
                    "resolution": float(g.resolution), "origin": _pose(origin),
                    "frame": _frame(g.header.frame_id), "rows": "top_first",
                    "data": base64.b64encode(np.ascontiguousarray(grey).tobytes()).decode()}
            return self._map_payload
