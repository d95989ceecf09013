"""Bus adapter of the collision monitor: between the master's ``cmd_vel`` and the base driver.

    python -m robot_side.safety.node --config FILE [--section KEY]

Subscribed: ``cmd_vel_in_topic`` (Twist, from the master) and each observation source's scan — the
robot's own sensors, on the robot PC: no network in this loop. Published: ``cmd_vel_out_topic`` (the
base driver's ``cmd_vel_topic``) and ``state_topic`` (CollisionMonitorState, latched; on change and at
``state_rate``). Every change of action is logged, so ``zenav robot`` shows it.

Timing, in the node's clock (sim time under the simulator):
- each input command is checked and forwarded at once;
- each new scan re-checks the current command; a stricter verdict is sent at once (a box that appears
  in front of the robot while the master is away stops it without waiting for the master);
- an input older than ``cmd_vel_timeout`` is replaced by explicit zeros for ``stop_pub_timeout``
  (the base brakes now instead of after its own timeout);
- a source silent for ``source_timeout`` stops the robot (no data, no motion).
"""

from __future__ import annotations

import logging
import math
import threading
import time

import numpy as np

from common.messages import CollisionMonitorState, Header, LaserScan, Twist
from common.tf import TFError, TFListener
from robot_side.safety.collision_monitor import CollisionMonitor, Verdict
from robot_side.safety.memory import PointMemory, View
from robot_side.safety.params import load_monitor, padded

__all__ = ["MonitorNode", "scan_points", "check", "start"]

log = logging.getLogger("zenav.collision_monitor")

TICK = 0.02  # s, wall: staleness checks


def scan_points(scan: LaserScan) -> np.ndarray:
    """(N, 2) points of the valid returns in the scan's frame."""
    r = np.asarray(scan.ranges, float)
    a = scan.angle_min + scan.angle_increment * np.arange(len(r))
    ok = np.isfinite(r) & (r >= scan.range_min) & (r <= scan.range_max) & np.isfinite(a)
    return np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])])


class MonitorNode:
    def __init__(self, node, cfg: dict, source: str) -> None:
        self.node = node
        self.p, self.sources, polys = load_monitor(cfg, source)
        fp = padded(self.p.footprint, self.p.footprint_padding) if self.p.footprint else None
        self.monitor = CollisionMonitor(polys, fp, self.p.rotation_center_x)
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self.tf = TFListener(node)
        self.seen: dict[str, float] = {}  # source -> clock time of its last usable scan
        self.memory = {n: PointMemory(sp.blind_zone_memory) for n, sp in self.sources.items()}
        self.cmd: tuple[float, float] = (0.0, 0.0)
        self.cmd_time = -math.inf
        self.sent: tuple[float, float] | None = None
        self.stale_since: float | None = None
        self.verdict = Verdict(0.0, 0.0, "none", reason="idle: no command yet")
        self.started: float | None = None  # first valid clock reading (sim time is 0 until the clock runs)
        self.out = node.publisher(self.p.cmd_vel_out_topic)
        self.state_pub = node.publisher(self.p.state_topic, latched=True, background=True)  # never waits on the link
        self._last_state: tuple = ()  # before the subscriptions: their callbacks publish the state
        self._last_state_time = 0.0
        self.subs = [node.subscribe(self.p.cmd_vel_in_topic, Twist, callback=self._on_cmd)]
        for name, sp in self.sources.items():
            if sp.enabled:
                self.subs.append(node.subscribe(sp.topic, LaserScan, callback=lambda s, n=name: self._on_scan(n, s)))
        self._publish_state(force=True)
        names = ", ".join(f"{n} ({pp.action_type})" for n, pp in polys if pp.enabled) or "none"
        node.log.info("collision monitor: %s -> %s, sources %s, polygons %s, cmd_vel timeout %g s%s",
                      self.p.cmd_vel_in_topic, self.p.cmd_vel_out_topic,
                      ", ".join(f"{n} ({s.topic})" for n, s in self.sources.items() if s.enabled) or "none",
                      names, self.p.cmd_vel_timeout, "" if self.p.enabled else " - DISABLED: commands pass through")
        self._thread = threading.Thread(target=self._run, name="collision_monitor", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ inputs
    def _on_cmd(self, twist: Twist) -> None:
        v, w = float(twist.linear.x), float(twist.angular.z)
        with self.lock:
            self.cmd, self.cmd_time, self.stale_since = (v, w), self.node.clock.now(), None
            self._decide_and_send(force=True)

    def _on_scan(self, name: str, scan: LaserScan) -> None:
        """The scan's points go to the odom frame (where they stay valid while the robot moves)."""
        p = self.p
        try:
            tr = self.tf.buffer.lookup(p.odom_frame_id, scan.header.frame_id, scan.header.stamp,
                                       timeout=p.transform_tolerance).transform
        except TFError as e:
            self.node.log.warning("collision monitor: no transform %s <- %s at the scan's stamp: %s",
                                  p.odom_frame_id, scan.header.frame_id, e)
            return
        pts = scan_points(scan)
        pts = tr.apply(np.column_stack([pts, np.zeros(len(pts))]))[:, :2] if len(pts) else pts
        view = View(tr.to_pose2d(), scan.angle_min, scan.angle_increment, np.asarray(scan.ranges, float))
        with self.lock:
            now = self.node.clock.now()
            self.memory[name].update(pts, view, now)
            self.seen[name] = now
            if self._input_fresh(now):
                self._decide_and_send(force=False)

    def _points_in_base(self) -> np.ndarray | None:
        """Every source's current and remembered points in the base frame now (None: no odom TF)."""
        parts = [m.points() for m in self.memory.values()]
        pts = np.vstack(parts) if parts else np.zeros((0, 2))
        try:
            tr = self.tf.buffer.lookup(self.p.base_frame_id, self.p.odom_frame_id).transform
        except TFError:
            return None
        return tr.apply(np.column_stack([pts, np.zeros(len(pts))]))[:, :2] if len(pts) else pts

    # ------------------------------------------------------------------ decision
    def _input_fresh(self, now: float) -> bool:
        return now - self.cmd_time <= self.p.cmd_vel_timeout

    def _silent_source(self, now: float) -> str:
        if self.started is None:
            if now <= 0.0:
                return "waiting for the clock"
            self.started = now
        for name, sp in self.sources.items():
            if not sp.enabled:
                continue
            t = self.seen.get(name, self.started)
            if now - t > self.p.source_timeout:
                return f"source '{name}' ({sp.topic}) silent for {now - t:.1f} s"
        return ""

    def _decide(self, now: float) -> Verdict:
        v, w = self.cmd
        if not self.p.enabled:
            return Verdict(v, w, "disabled", reason="monitor disabled by its config")
        silent = self._silent_source(now)
        if silent:
            return Verdict(0.0, 0.0, "no_data", ratio=0.0, reason=silent)
        pts = self._points_in_base()
        if pts is None:
            return Verdict(0.0, 0.0, "no_data", ratio=0.0, reason=f"no transform {self.p.base_frame_id} <- "
                                                                   f"{self.p.odom_frame_id}")
        return self.monitor.check(pts, v, w)

    def _decide_and_send(self, force: bool) -> None:
        """Under the lock. ``force``: a new input (always forwarded); else only a stricter verdict."""
        verdict = self._decide(self.node.clock.now())
        out = (verdict.v, verdict.w)
        if force or (self.sent is not None and _stricter(out, self.sent)):
            self._send(out)
        self.verdict = verdict
        self._publish_state()

    def _send(self, out: tuple[float, float]) -> None:
        self.sent = out
        self.out.publish(Twist.planar(*out))

    # ------------------------------------------------------------------ timer
    def _run(self) -> None:
        while not self._stop.wait(TICK):
            try:
                self._tick()
            except Exception:  # noqa: BLE001 - the monitor must keep running
                log.exception("collision monitor tick failed")

    def _tick(self) -> None:
        with self.lock:
            now = self.node.clock.now()
            if self.cmd_time == -math.inf:  # idle: the state still tells whether the sources are alive
                silent = self._silent_source(now) if self.p.enabled else ""
                self.verdict = (Verdict(0.0, 0.0, "no_data", ratio=0.0, reason=silent) if silent
                                else Verdict(0.0, 0.0, "none", reason="idle: no command yet"))
            elif not self._input_fresh(now):
                if self.stale_since is None:
                    self.stale_since = now
                    self.verdict = Verdict(0.0, 0.0, "stale_cmd", ratio=0.0,
                                           reason=f"no cmd_vel for {self.p.cmd_vel_timeout:g} s: zero sent")
                if now - self.stale_since <= self.p.stop_pub_timeout or self.sent != (0.0, 0.0):
                    self._send((0.0, 0.0))
            self._publish_state()

    # ------------------------------------------------------------------ state
    def _publish_state(self, force: bool = False) -> None:
        vd, (v, w) = self.verdict, self.cmd
        key = (vd.action, vd.polygon)
        wall = time.monotonic()
        changed = key != self._last_state
        if not (force or changed or wall - self._last_state_time >= 1.0 / self.p.state_rate):
            return
        if changed and self._last_state:
            level = logging.INFO if vd.action in ("none", "disabled") else logging.WARNING
            self.node.log.log(level, "collision monitor: %s%s%s", vd.action,
                              f" by '{vd.polygon}'" if vd.polygon else "", f": {vd.reason}" if vd.reason else "")
        self._last_state, self._last_state_time = key, wall
        out = self.sent or (0.0, 0.0)
        self.state_pub.publish(CollisionMonitorState(
            Header(self.node.clock.now(), self.p.base_frame_id), vd.action, vd.polygon, vd.reason,
            float(vd.ratio), int(vd.points), v, w, out[0], out[1]))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for s in self.subs:
            s.close()
        self.tf.close()


def _stricter(new: tuple[float, float], old: tuple[float, float]) -> bool:
    return abs(new[0]) < abs(old[0]) - 1e-3 or abs(new[1]) < abs(old[1]) - 1e-3


def check(cfg: dict, source: str) -> list[str]:
    """The agents' pre-start check (common.node_check)."""
    notes: list = []
    load_monitor(cfg, source, notes)
    return notes


def start(node, cfg: dict, source: str) -> MonitorNode:
    return MonitorNode(node, cfg, source)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("collision_monitor", start))
