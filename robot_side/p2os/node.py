"""p2os bus node: a real Pioneer (P2OS / ARCOS over a serial port) publishing exactly what the
simulated base publishes (robot_side/sim/node.py), so the master side cannot tell them apart.

    python -m robot_side.p2os.node --config FILE [--section KEY]

Parameters: ``robot_side.p2os.driver.P2OSParams`` (ROS p2os_driver names: ``port`` — a device or a
pyserial URL such as ``loop://`` / ``socket://host:port`` —, ``baud``, ``pulse``, ``use_sonar``, plus
``motors_on_start``, ``cmd_vel_timeout``, ``max_xspeed``, ``max_yawspeed``, frames, battery range).

Published (wall-clock stamps)::

    odom                 Odometry       odom -> base_link, every SIP (~10 Hz), twist from the wheel speeds
    tf                   TFMessage      odom -> base_link, with every odom message
    motor_state (latched) MotorState    1 Hz + on change (the SIP's motors-enabled flag)
    battery_state        BatteryState   1 Hz (SIP voltage; percentage linear between the empty/full volts)
    bumper_state         BumperState    every SIP: 5 front and 5 rear segments (ARIA's robot parameters for a
                                        Pioneer 3), segment i from SIP bit i + 1 (p2os_driver's order; which
                                        end is segment 0 on a real P3-AT is not checked here)
    sonar                SonarArray     every SIP with ``use_sonar``: each sonar's latest range (m, by sonar
                                        number; a SIP carries the sonars fired since the last; +inf for one
                                        not heard from yet), for robot_side/sonar/node.py

Subscribed: ``cmd_vel`` (Twist -> VEL mm/s + RVEL deg/s, clamped; zero after ``cmd_vel_timeout``) and
``cmd_motor_state`` (MotorState -> ENABLE). Motors are enabled on start unless ``motors_on_start`` is
false (the tutorial's ``rostopic pub /cmd_motor_state ... 1`` is not needed).
"""

from __future__ import annotations

import logging
import math
import threading

from common.config import ConfigError, load_params
from common.messages import (
    BatteryState,
    BumperState,
    Header,
    MotorState,
    Odometry,
    SonarArray,
    TransformStamped,
    Twist,
)
from common.tf import TFBroadcaster
from robot_side.device_node import DeviceNode, start_or_exit
from robot_side.p2os.driver import BaseState, P2OSConnectionError, P2OSDriver, P2OSParams, open_port

log = logging.getLogger("zenav.p2os")
BUMPER_SEGMENTS = 5  # per bumper, front and rear (ARIA's robot parameters for the Pioneer 3)
SONARS = 16  # a Pioneer 3's two rings of 8 (ARIA's p3at / p3dx tables)


def load(cfg: dict | None, source: str) -> P2OSParams:
    p = load_params(P2OSParams, cfg, source)
    if p.battery_full_voltage <= p.battery_empty_voltage:
        raise ConfigError(source, "battery_full_voltage", "must be > battery_empty_voltage")
    return p


class P2OSNode(DeviceNode):
    def __init__(self, node, p: P2OSParams, port=None) -> None:
        super().__init__(node)
        self.p = p
        self.pub_odom = node.publisher("odom")
        self.tf = TFBroadcaster(node)
        self.pub_motor = node.publisher("motor_state", latched=True, background=True)  # never waits on the link
        self.pub_battery = node.publisher("battery_state")
        self.pub_bumper = node.publisher("bumper_state")
        self._lock = threading.Lock()
        self._motors_sent: bool | None = None
        self._motor_t = self._battery_t = -1e9
        # before connect(): its handshake hands the first SIP to _on_state already
        self.pub_sonar = node.publisher("sonar") if p.use_sonar else None
        self._sonar = [math.inf] * SONARS  # grows if a SIP names a higher sonar number
        self.driver = P2OSDriver(port if port is not None else open_port(p.port, p.baud), p,
                                 on_state=self._on_state)
        try:
            info = self.driver.connect()
        except Exception:
            self.driver.close()
            raise
        node.log.info("p2os: %s (%s %s) on %s, %d baud, pulse %g s, motors %s on start, %s timeout %g s",
                      info.name, info.robot_class, info.subclass, p.port, p.baud, p.pulse,
                      "enabled" if p.motors_on_start else "left", p.cmd_vel_topic, p.cmd_vel_timeout)
        self.driver.start()  # first: a motor command taken in before start() would be marked sent unsent
        self.subs = [node.subscribe(p.cmd_vel_topic, Twist, callback=self._on_cmd_vel),
                     node.subscribe("cmd_motor_state", MotorState, callback=self._on_motor_state)]
        self.watch(1.0, self._check)

    def _on_cmd_vel(self, t: Twist) -> None:
        self.driver.set_cmd_vel(t.linear.x, t.angular.z)

    def _on_motor_state(self, m: MotorState) -> None:
        self.driver.set_motors(bool(m.enabled))

    def _on_state(self, s: BaseState) -> None:
        p, r = self.p, s.reading
        now = self.node.clock.now()
        tf = s.pose.to_transform()
        twist = Twist.planar(r.v, r.w)  # as the wheels measure it, also when the pose pivots (odom_rotation_center_x)
        self.pub_odom.publish(Odometry(Header(now, p.odom_frame_id), p.base_frame_id, tf, twist))
        self.tf.send(TransformStamped(Header(now, p.odom_frame_id), p.base_frame_id, tf))
        with self._lock:
            motor_due = r.motors_enabled != self._motors_sent or now - self._motor_t >= 1.0
            battery_due = now - self._battery_t >= 1.0
            if motor_due:
                self._motors_sent, self._motor_t = r.motors_enabled, now
            if battery_due:
                self._battery_t = now
        if motor_due:
            self.pub_motor.publish(MotorState(Header(now, p.base_frame_id), r.motors_enabled))
        if battery_due:
            span = p.battery_full_voltage - p.battery_empty_voltage
            frac = min(1.0, max(0.0, (r.battery_voltage - p.battery_empty_voltage) / span))
            self.pub_battery.publish(BatteryState(Header(now, p.base_frame_id), r.battery_voltage, frac))
        self.pub_bumper.publish(BumperState(Header(now, p.base_frame_id),
                                            tuple(bool(r.bumpers >> i & 1) for i in range(BUMPER_SEGMENTS)),
                                            tuple(bool(r.bumpers >> (8 + i) & 1) for i in range(BUMPER_SEGMENTS))))
        if self.pub_sonar is not None:
            for i, rng in r.sonar_ranges:
                if i >= len(self._sonar):
                    self._sonar.extend([math.inf] * (i + 1 - len(self._sonar)))
                self._sonar[i] = rng
            self.pub_sonar.publish(SonarArray(Header(now, p.base_frame_id), tuple(self._sonar)))
        if r.left_stalled or r.right_stalled:
            log.debug("wheel stall: left %s right %s", r.left_stalled, r.right_stalled)

    def _check(self) -> None:
        d = self.driver
        if d.error is not None and not self.lost:
            self.pub_motor.publish(MotorState(Header(self.node.clock.now(), self.p.base_frame_id), False))
            self.device_lost("p2os: serial I/O on %s failed (%s); the base is no longer driven; "
                             "exiting so the agent can restart the driver", self.p.port, d.error)

    def close(self) -> None:
        self.unwatch()
        for s in self.subs:
            s.close()
        self.driver.close()  # motors stopped, then CLOSE


def start(node, cfg: dict, source: str) -> P2OSNode:
    p = load(cfg, source)
    return start_or_exit("p2os", lambda: P2OSNode(node, p), P2OSConnectionError)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("p2os", start))
