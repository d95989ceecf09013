"""Simulator bus node: the simulated robot publishes what the real drivers publish, on the same keys.

    python -m robot_side.sim.node --config FILE [--section KEY] [--world W] [--start X Y YAW] [--speed N]

Mapping: ``world`` (default ``room``), ``start``, ``world_params``, ``sim``, ``base``, ``laser``,
``depth_camera`` (see ``Simulator.from_config``; here a sensor exists only when its key is present and
not null/false — ``laser: {}`` for the defaults) plus the node keys of ``SimNodeParams`` (``speed``,
``start_time``, rates, battery, ``mount_tf``).

Published (all stamps sim time; sim time starts at the wall time at start unless ``start_time``)::

    clock                       Clock           every physics step (dt = sim.dt, 100 Hz sim time) up to 1x real
                                                time; faster, once per wake-up of the physics (CLOCK_WALL_PERIOD,
                                                10 ms of wall time), with the last step run then
    odom                        Odometry        odom -> base_link, odom_rate (50 Hz sim time)
    tf                          TFMessage       odom -> base_link, with every odom message
    tf_static (latched)         TFMessage       base_link -> laser, base_link -> camera_link (mount_tf),
                                                camera_link -> camera_depth_frame (identity, or see
                                                mount_tf) -> camera_depth_optical_frame
    scan (laser.topic)          LaserScan       laser.rate, when a laser is configured (a Jackal: front/scan)
    camera/depth/image          DepthImage      depth_camera.rate / (data_skip + 1), when configured
    camera/depth/camera_info    CameraInfo      with every depth image
    sonar (sonar.topic)         SonarArray      sonar.rate, when a sonar ring is configured (robot_side/sim/sonar.py)
    ground_truth                Odometry        map -> base_link, ground_truth_rate (evaluation only)
    collision (latched)         Collision       on each new collision (count since start)
    bumper_state                BumperState     bumper_rate, when set: the segments a contact pressed since the last
    motor_state (latched)       MotorState      motor_state_rate (1 Hz) + on change
    battery_state               BatteryState    battery_rate (1 Hz), a slowly draining fake

Subscribed: ``cmd_vel_topic`` (Twist, default ``cmd_vel``; behind the collision monitor
``safety/cmd_vel``; the timeout ``base.cmd_vel_timeout`` runs in sim time) and
``cmd_motor_state`` (MotorState; disabled motors ignore cmd_vel), ``sim/spawn_box`` (SpawnBox: a box
appears, in the world or relative to the robot; for tests and demos of the robot's own safety).
The physics runs on its own thread paced by ``Pacer`` at ``speed`` x real time; when the machine cannot
keep up for more than ``max_lag`` wall seconds, the sim runs slower instead of bursting to catch up.
The sensor mounts' transforms are ``robot_side.sim.mounts_node``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from typing import Any

import numpy as np

from common.geometry import Pose2D
from common.messages import BatteryState, BumperState, Clock, Header, MotorState, SpawnBox, Twist
from common.tf import StaticTFBroadcaster, TFBroadcaster, TFListener
from robot_side.bumpers.geometry import BumperParams, PressLatch
from robot_side.sim.mounts_node import SensorMounts
from robot_side.sim.node_params import SimNodeParams, describe, load
from robot_side.sim.simulator import Pacer, Simulator

log = logging.getLogger("zenav.sim")
# Wall time between the physics thread's wake-ups: above 1x real time the steps due run together and the
# clock goes out once for them, with the last (a message of an earlier step of the wake-up can arrive
# before the clock has reached its stamp: at most 10 ms of wall time ahead). Every node on sim time handles each
# clock message (about 2 % of a core per process at 100 per second: bench/stack_cpu.py), so at 2x a
# clock per step doubled that for every process while giving no node a finer view of wall time.
CLOCK_WALL_PERIOD = 0.01


def _restamp(msg: Any, offset: float) -> Any:
    return dataclasses.replace(msg, header=dataclasses.replace(msg.header, stamp=msg.header.stamp + offset))


class _Tick:
    """True once per period of sim time: at one period, two periods, ... (t = 0 precedes every step)."""

    def __init__(self, rate: float) -> None:
        self.rate, self.last = rate, 0

    def __call__(self, t: float) -> bool:
        k = math.floor(t * self.rate + 1e-6)
        if k > self.last:
            self.last = k
            return True
        return False


class SimNode:
    def __init__(self, node, p: SimNodeParams, sim: Simulator, world_path: str = "") -> None:
        self.node, self.p, self.sim = node, p, sim
        self.speed = p.speed if p.speed is not None else sim.params.real_time_factor
        self.offset = time.time() if p.start_time is None else p.start_time
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self.lag_events = 0
        pub = node.publisher
        self.pub_clock, self.pub_odom = pub("clock"), pub("odom")
        self.tf = TFBroadcaster(node)
        self.static = StaticTFBroadcaster(node)
        self.pub_gt = pub("ground_truth")
        # states from the loop: never wait on a cut link to the master (common/bus_sender.py)
        self.pub_collision = pub("collision", latched=True, background=True)
        self.pub_motor = pub("motor_state", latched=True, background=True)
        self.pub_battery = pub("battery_state")
        self.pub_scan = pub(sim.laser.p.topic) if sim.laser else None
        self.pub_depth = pub("camera/depth/image") if sim.camera else None
        self.pub_info = pub("camera/depth/camera_info") if sim.camera else None
        self.pub_sonar = pub(sim.sonar.p.topic) if sim.sonar else None
        self._odom_tick, self._gt_tick = _Tick(p.odom_rate), _Tick(p.ground_truth_rate)
        self._motor_tick, self._battery_tick = _Tick(p.motor_state_rate), _Tick(p.battery_rate)
        self._collisions = sim.base.collisions
        # (the presses since the last report, its publisher) when the robot has bumpers
        self.bumpers = (PressLatch(BumperParams()), pub("bumper_state")) if p.bumper_rate > 0 else None
        self._bumper_tick = _Tick(p.bumper_rate)
        self._motors_sent: bool | None = None
        self.mounts = SensorMounts(node, sim, p, self.static, self.offset)
        self.static.send(self.mounts.transforms())
        self._listener = None
        if not p.mount_tf:
            self._listener = TFListener(node, static_only=True)  # mounts come on tf_static
            threading.Thread(target=self.mounts.follow, args=(self._listener, self._stop), name="sim:mount_tf",
                             daemon=True).start()
        self.subs = [node.subscribe(p.cmd_vel_topic, Twist, callback=self._on_cmd_vel),
                     node.subscribe("cmd_motor_state", MotorState, callback=self._on_motor_state),
                     node.subscribe("sim/spawn_box", SpawnBox, callback=self._on_spawn_box)]
        node.log.info("%s", describe(sim, p, self.speed, world_path))
        if sim.sonar is not None:  # its compiled cast loads (or compiles) now, not in the first step's clock
            sim.sonar.warm()
        self._thread = threading.Thread(target=self._run, name="sim:loop", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ inputs
    def _on_cmd_vel(self, twist: Twist) -> None:
        with self.lock:
            self.sim.cmd_vel(twist)

    def _on_spawn_box(self, msg: SpawnBox) -> None:
        with self.lock:
            at = Pose2D(msg.x, msg.y, msg.yaw)
            if msg.header.frame_id == self.sim.base.p.base_frame_id:
                at = self.sim.base.pose.compose(at)
            elif msg.header.frame_id not in ("map", "world", ""):
                self.node.log.warning("sim/spawn_box: frame %r is neither map nor %s: ignored",
                                      msg.header.frame_id, self.sim.base.p.base_frame_id)
                return
            try:
                self.sim.add_box(at.x, at.y, msg.size_x, msg.size_y, msg.height, at.theta)
            except ValueError as e:
                self.node.log.warning("sim/spawn_box: %s", e)
                return
        self.node.log.info("simulator: box %.2f x %.2f m spawned at x=%.3f y=%.3f (world)", msg.size_x,
                           msg.size_y, at.x, at.y)

    def _on_motor_state(self, msg: MotorState) -> None:
        with self.lock:
            self.sim.set_motors(bool(msg.enabled))
            out = self._motor_msg()
        self.pub_motor.publish(out)

    def _motor_msg(self) -> MotorState:
        self._motors_sent = self.sim.base.motors_enabled
        return _restamp(self.sim.motor_state(), self.offset)

    # ------------------------------------------------------------------ loop
    def _run(self) -> None:
        dt, pacer = self.sim.params.dt, Pacer(self.speed)
        t0, sim0 = time.monotonic(), self.sim.time
        woke = t0 - CLOCK_WALL_PERIOD  # the planned time of the last wake-up
        while not self._stop.is_set():
            n = pacer.steps_due(time.monotonic() - t0, self.sim.time - sim0, dt)
            if n == 0:
                # at most one wake-up per CLOCK_WALL_PERIOD: faster than real time, the steps due by then
                # run together and the clock goes out once for them (see _step)
                woke = max(t0 + (self.sim.time - sim0 + dt) / self.speed, woke + CLOCK_WALL_PERIOD)
                self._stop.wait(max(0.0, woke - time.monotonic()))
                continue
            for i in range(n):
                if self._stop.is_set():
                    return
                try:
                    self._step(clock=i == n - 1)
                except Exception:  # noqa: BLE001 - a bad step must not silently kill the robot's clock
                    log.exception("simulation step failed")
            behind = (time.monotonic() - t0) - (self.sim.time - sim0) / self.speed
            if behind > self.p.max_lag:
                t0 = time.monotonic() - (self.sim.time - sim0) / self.speed
                self.lag_events += 1
                if self.lag_events == 1 or self.lag_events % 20 == 0:
                    log.warning("simulator cannot keep up with %gx real time (%.2f s behind, #%d): "
                                "running slower", self.speed, behind, self.lag_events)

    def _step(self, clock: bool = True) -> None:
        """One physics step and what it publishes, each step's messages as it runs (a wake-up's steps sent
        at once could overflow Zenoh's send queue: stream messages are dropped then). The clock goes
        out with the last step of a wake-up, before that step's messages."""
        sim, off = self.sim, self.offset
        out: list[tuple[Any, Any]] = []  # (publisher or TF broadcaster, message)
        with self.lock:
            due = sim.step()
            t = sim.time
            if clock:
                out.append((self.pub_clock, Clock(t + off)))
            if self._odom_tick(t):
                out.append((self.pub_odom, _restamp(sim.odometry(), off)))
                out.append((self.tf, _restamp(sim.odom_transform(), off)))
            if self._gt_tick(t):
                out.append((self.pub_gt, _restamp(sim.ground_truth_odometry(), off)))
            if sim.base.collisions != self._collisions:
                self._collisions = sim.base.collisions
                c = sim.collision()
                g = sim.base.pose
                log.warning("collision #%d at (%.2f, %.2f) in %s; robot at (%.2f, %.2f, %.2f rad)", c.count, c.x, c.y,
                            c.header.frame_id, g.x, g.y, g.theta)
                out.append((self.pub_collision, _restamp(c, off)))
            if self.bumpers is not None:
                latch, pub_bumper = self.bumpers
                if sim.base.in_contact and sim.base.contact is not None:
                    latch.note(tuple(sim.base.pose.inverse().apply(np.array([sim.base.contact]))[0]))
                if self._bumper_tick(t):
                    out.append((pub_bumper, BumperState(Header(t + off, sim.base.p.base_frame_id), *latch.take())))
            if self._motor_tick(t) or sim.base.motors_enabled != self._motors_sent:
                out.append((self.pub_motor, self._motor_msg()))
            if self._battery_tick(t):
                out.append((self.pub_battery, self._battery(t + off)))
            if "laser" in due:
                out.append((self.pub_scan, _restamp(sim.scan(), off)))
            if "sonar" in due:
                out.append((self.pub_sonar, _restamp(sim.sonar_reading(), off)))
            if "depth_camera" in due:
                img, info = sim.depth_frame()
                out.append((self.pub_info, _restamp(info, off)))
                out.append((self.pub_depth, _restamp(img, off)))
        for pub, msg in out:
            if pub is self.tf:
                pub.send(msg)
            else:
                pub.publish(msg)

    def _battery(self, stamp: float) -> BatteryState:
        p = self.p
        frac = max(0.0, p.battery_start - p.battery_drain_per_hour * self.sim.time / 3600.0)
        volts = p.battery_empty_voltage + frac * (p.battery_full_voltage - p.battery_empty_voltage)
        return BatteryState(Header(stamp, self.sim.base.p.base_frame_id), volts, frac)

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(5.0)
        for sub in self.subs:
            sub.close()
        if self._listener is not None:
            self._listener.close()


def check(cfg: dict, source: str) -> list[str]:
    """The agents' check before start: parameters, world file and sensors load (raises ConfigError)."""
    load(cfg, source)
    return []


def warm_before_fork() -> None:
    """(common.fork_server) The sonar ring's compiled cast, loaded once for every simulator forked after."""
    from robot_side.sim.sonar import warm_kernel

    warm_kernel()


def start(node, cfg: dict, source: str) -> SimNode:
    p, sim, world = load(cfg, source)
    return SimNode(node, p, sim, world)


def main(argv: list[str] | None = None) -> int:
    """``node_main`` plus the simulator's own overrides: --world, --start X Y YAW, --speed N."""
    import argparse

    from common.runner import node_main

    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--world")
    ap.add_argument("--start", nargs=3, type=float)
    ap.add_argument("--speed", type=float)
    ap.add_argument("--start-time", dest="start_time", type=float)
    over, rest = ap.parse_known_args(argv)
    extra = {k: v for k, v in vars(over).items() if v is not None}

    def start_with_overrides(node, cfg: dict, source: str) -> SimNode:
        return start(node, {**(cfg or {}), **extra}, source)

    return node_main("sim", start_with_overrides, rest)


if __name__ == "__main__":
    raise SystemExit(main())
