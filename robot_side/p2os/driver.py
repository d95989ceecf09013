"""Pioneer base driver over any pyserial-like port (``read``/``write``/``close``): no bus here.

    port = open_port("/dev/ttyUSB0", 9600)          # or "loop://", "socket://host:port", a pty path
    drv = P2OSDriver(port, P2OSParams(), on_state=print)
    info = drv.connect()        # SYNC0/1/2 handshake (retried), OPEN, PULSE, SONAR, ENABLE; first SIP
    drv.start()                 # I/O thread: SIPs -> BaseState, cmd_vel -> VEL/RVEL, PULSE keepalive
    drv.set_cmd_vel(0.3, 0.2)   # m/s, rad/s; clamped; zeroed after cmd_vel_timeout without a new one
    drv.close()                 # STOP + VEL 0 + RVEL 0, then CLOSE

One thread owns the port after ``start()``; ``set_cmd_vel`` / ``set_motors`` only store set points.
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

from common.config import param
from common.geometry import Pose2D
from robot_side.p2os import protocol as P
from robot_side.p2os.sip import (
    MODELS,
    BaseReading,
    OdometryIntegrator,
    RobotModel,
    decode_sip,
    is_sip,
    model_for,
    parse_sync2,
    to_si,
)

log = logging.getLogger("zenav.p2os")


@dataclass(frozen=True)
class P2OSParams:
    """p2os_driver parameters (ROS names) plus the zenav extras."""

    port: str = param("/dev/ttyUSB0", doc="serial device, or a pyserial URL (loop://, socket://h:p)")
    baud: int = param(9600, choices=(9600, 19200, 38400, 57600, 115200), doc="serial baud rate")
    pulse: float = param(1.0, lo=0.05, hi=1.9, unit="s", doc="PULSE keepalive period (robot watchdog 2 s)")
    use_sonar: bool = param(False, doc="switch the sonar arrays on; the node publishes the readings on sonar")
    motors_on_start: bool = param(True, doc="ENABLE the motors after connecting")
    cmd_vel_timeout: float = param(0.25, lo=0.0, hi=60.0, unit="s", doc="command zero when cmd_vel is older")
    cmd_vel_topic: str = param("cmd_vel", doc="velocity commands (safety/cmd_vel behind the collision monitor)")
    trans_decel: float | None = param(None, lo=0.01, hi=5.0, unit="m/s^2",
                                      doc="SETA braking rate sent on connect; default: the robot's own setting")
    rot_decel: float | None = param(None, lo=0.01, hi=20.0, unit="rad/s^2",
                                    doc="SETRA braking rate sent on connect; default: the robot's own setting")
    max_xspeed: float = param(0.5, lo=0.0, hi=1.2, unit="m/s", doc="translational speed limit")
    max_yawspeed: float = param(math.radians(100), lo=0.0, hi=math.radians(300), unit="rad/s",
                                doc="rotational speed limit")
    robot_model: str = param("auto", choices=("auto", *MODELS),
                             doc="conversion factors; auto = from the SYNC2 subclass")
    position_wrap_bits: int = param(12, choices=(12, 15), doc="SIP x/y counter wrap used for odometry")
    odom_rotation_center_x: float = param(
        0.0, lo=-2.0, hi=2.0, unit="m",
        doc="zenav: where on base_link's x axis the base turns about. The firmware integrates every turn "
            "about the axles' middle; a skid-steered base pivots toward its more loaded axle and moves "
            "base_link sideways as it turns, which the odometry then adds. 0: as the firmware (ROS p2os)")
    sync_timeout: float = param(0.5, lo=0.01, hi=10.0, unit="s", doc="wait for each SYNC echo")
    sync_retries: int = param(5, lo=1, hi=100, doc="attempts per SYNC step before giving up")
    sip_timeout: float = param(2.0, lo=0.1, hi=30.0, unit="s", doc="wait for the first SIP after OPEN")
    odom_frame_id: str = param("odom", doc="odometry frame")
    base_frame_id: str = param("base_link", doc="robot frame", aliases=("base_link_frame_id",))
    battery_empty_voltage: float = param(11.0, lo=0.0, hi=100.0, unit="V", doc="0 % for battery_state")
    battery_full_voltage: float = param(12.8, lo=0.0, hi=100.0, unit="V", doc="100 % (12 V SLA)")


class P2OSConnectionError(RuntimeError):
    """The robot did not answer (or not as a P2OS robot)."""


@dataclass(frozen=True)
class RobotInfo:
    name: str
    robot_class: str
    subclass: str
    model: RobotModel


@dataclass(frozen=True)
class BaseState:
    """What the driver knows after each SIP (SI units; pose continuous in the odom frame)."""

    stamp: float  # monotonic seconds when the SIP was read
    pose: Pose2D
    reading: BaseReading
    sips: int


def open_port(url: str, baud: int = 9600, timeout: float = 0.02) -> Any:
    """A pyserial port for a device path or URL; an error names the port."""
    import serial

    try:
        return serial.serial_for_url(url, baudrate=baud, timeout=timeout, write_timeout=2.0)
    except (serial.SerialException, ValueError, OSError) as e:
        raise P2OSConnectionError(f"cannot open the robot's serial port {url!r}: {e}") from e


class P2OSDriver:
    def __init__(self, port: Any, params: P2OSParams = P2OSParams(),
                 on_state: Callable[[BaseState], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.port, self.p, self.on_state, self.clock = port, params, on_state, clock
        self.port_name = params.port
        self.parser = P.PacketParser()
        self.info: RobotInfo | None = None
        self.odometry: OdometryIntegrator | None = None
        self.state: BaseState | None = None
        self.error: Exception | None = None
        self.undecodable = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._target = (0.0, 0.0)  # m/s, rad/s
        self._target_time = -math.inf
        self._motors_wanted: bool | None = None
        self._motors_sent: bool | None = None
        self._closed = False
        self._sent_cmd: tuple[int, int] | None = None
        self._last_write = -math.inf
        self._skipped: list[bytes] = []  # packets _wait_packet passed over

    # ------------------------------------------------------------------ low level
    def _write(self, packet: bytes) -> None:
        self.port.write(packet)
        self._last_write = self.clock()

    def _read_packets(self) -> list[bytes]:
        n = max(1, getattr(self.port, "in_waiting", 0) or 0)
        data = self.port.read(n)
        return self.parser.feed(data) if data else []

    def _wait_packet(self, timeout: float, want: Callable[[bytes], bool]) -> bytes | None:
        """The first packet satisfying ``want``; the others are appended to ``self._skipped``."""
        deadline = self.clock() + timeout
        while self.clock() < deadline:
            for body in self._read_packets():
                if want(body):
                    return body
                self._skipped.append(body)
        return None

    # ------------------------------------------------------------------ connect
    def connect(self) -> RobotInfo:
        """Handshake, OPEN, motors and sonar as configured; returns once the first SIP is decoded."""
        p = self.p
        with_reset = getattr(self.port, "reset_input_buffer", None)
        if with_reset:
            with_reset()
        step, tries, restarts, reply = 0, 0, 0, b""
        while step < 3:
            if tries >= p.sync_retries:
                raise P2OSConnectionError(
                    f"no answer from a P2OS robot on {self.port_name} at {p.baud} baud: SYNC{step} sent "
                    f"{tries} times without its echo (waited {p.sync_timeout:g} s each). Check that the "
                    f"robot is switched on, the cable, the port name and the baud rate.")
            self._skipped = []
            if step == 0 and tries and tries % 2 == 0:
                # SYNC0 unanswered twice: a robot left synchronised but not open (its SYNC2 echo lost)
                # takes SYNC0 for PULSE; CLOSE returns it to the start of the handshake
                self._write(P.close())
            self._write(P.sync(step))
            tries += 1
            def echo(b: bytes, s: int = step) -> bool:  # the robot's echo of SYNC s
                return b[0] == s and not is_sip(b)

            body = self._wait_packet(p.sync_timeout, echo)
            if body is not None:
                step, tries, reply = step + 1, 0, body
            elif step > 0:
                step = 0  # a lost echo mid-handshake: start over from SYNC0 (tries keep counting)
            elif any(is_sip(b) for b in self._skipped):
                # still open from an earlier client (a crashed driver): CLOSE and start over
                restarts += 1
                if restarts > p.sync_retries:
                    raise P2OSConnectionError(f"the robot on {self.port_name} keeps streaming SIPs and "
                                              f"does not accept CLOSE")
                self._write(P.close())
                step, tries = 0, 0
        name, cls, subclass = parse_sync2(reply)
        model = MODELS[p.robot_model] if p.robot_model != "auto" else model_for(subclass)
        if model is None:
            model = MODELS["p3at-sh"]
            log.warning("unknown robot subclass %r from %s: using the p3at-sh conversion factors "
                        "(set robot_model to choose)", subclass, self.port_name)
        self.info = RobotInfo(name, cls, subclass, model)
        self.odometry = OdometryIntegrator(model, p.position_wrap_bits, p.odom_rotation_center_x)
        self._write(P.open_())
        self._write(P.pulse())
        self._write(P.sonar(p.use_sonar))
        if p.trans_decel is not None:  # a negative SETA / SETRA argument sets the deceleration
            self._write(P.command(P.Command.SETA, -round(p.trans_decel * 1000.0)))
        if p.rot_decel is not None:
            self._write(P.command(P.Command.SETRA, -round(math.degrees(p.rot_decel))))
        if p.motors_on_start:
            self._write(P.enable(True))
            self._motors_wanted = True
        self._skipped = []
        first = self._wait_packet(p.sip_timeout, is_sip)
        if first is None:
            raise P2OSConnectionError(f"the robot on {self.port_name} ({name} {cls} {subclass}) answered "
                                      f"the handshake but sent no SIP within {p.sip_timeout:g} s of OPEN")
        self._handle(first)
        log.debug("connected to %s (%s %s) on %s at %d baud; DistConvFactor %g", name, cls, subclass,
                  self.port_name, p.baud, model.dist_conv_factor)
        return self.info

    # ------------------------------------------------------------------ commands (any thread)
    def set_cmd_vel(self, v: float, w: float) -> None:
        """Velocity set point in m/s and rad/s; kept for cmd_vel_timeout."""
        with self._lock:
            self._target = (float(v), float(w))
            self._target_time = self.clock()

    def set_motors(self, enabled: bool) -> None:
        with self._lock:
            self._motors_wanted = bool(enabled)
            self._motors_sent = None

    def command_mm_deg(self, now: float) -> tuple[int, int]:
        """The VEL (mm/s) and RVEL (deg/s) due now: clamped, zero when cmd_vel is stale."""
        p, m = self.p, (self.info.model if self.info else MODELS["p3at"])
        with self._lock:
            v, w = self._target if now - self._target_time <= p.cmd_vel_timeout else (0.0, 0.0)
        vmax = min(p.max_xspeed * 1000.0, m.max_vel_mm_s)
        wmax = min(math.degrees(p.max_yawspeed), m.max_rvel_deg_s)
        if not (math.isfinite(v) and math.isfinite(w)):
            v = w = 0.0
        return (round(max(-vmax, min(vmax, v * 1000.0))), round(max(-wmax, min(wmax, math.degrees(w)))))

    # ------------------------------------------------------------------ I/O thread
    def start(self) -> None:
        if self.info is None:
            raise RuntimeError("connect() first")
        self._motors_sent = self._motors_wanted
        self._thread = threading.Thread(target=self._run, name="p2os:io", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                for body in self._read_packets():
                    self._handle(body)
                self._write_due(self.clock())
        except Exception as e:  # noqa: BLE001 - a lost port ends the loop; the node reports it
            self.error = e
            log.error("p2os I/O on %s stopped: %s", self.port_name, e)

    def _handle(self, body: bytes) -> None:
        if not is_sip(body):
            return  # config / echo / other packet types: not used
        try:
            sip = decode_sip(body)
        except P.ProtocolError:
            self.undecodable += 1
            return
        pose = self.odometry.update(sip)
        n = self.state.sips + 1 if self.state else 1
        self.state = BaseState(self.clock(), pose, to_si(sip, self.info.model), n)
        if self.on_state is not None:
            try:
                self.on_state(self.state)
            except Exception:  # noqa: BLE001 - a publishing error must not stop the base
                log.exception("on_state callback failed")

    def _write_due(self, now: float) -> None:
        with self._lock:
            motors = self._motors_wanted if self._motors_wanted != self._motors_sent else None
            self._motors_sent = self._motors_wanted
        if motors is not None:
            self._write(P.enable(motors))
        cmd = self.command_mm_deg(now)
        if cmd != self._sent_cmd:
            self._write(P.vel(cmd[0]) + P.rvel(cmd[1]))
            self._sent_cmd = cmd
        if now - self._last_write >= self.p.pulse:
            self._write(P.pulse())

    # ------------------------------------------------------------------ shutdown
    def close(self) -> None:
        """Stop the motors, then CLOSE the connection and the port (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        try:
            if self.info is not None and self.error is None:
                self._write(P.vel(0) + P.rvel(0) + P.stop())
                self._write(P.close())
                flush = getattr(self.port, "flush", None)
                if flush:
                    flush()
        except Exception as e:  # noqa: BLE001 - closing a dead port
            log.warning("could not send STOP/CLOSE on %s: %s", self.port_name, e)
        finally:
            with contextlib.suppress(Exception):
                self.port.close()
