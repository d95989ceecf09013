"""A simulated Pioneer (P2OS/ARCOS *device*) on the far end of a serial port, for tests and for trying
the driver without a robot:

    python -m robot_side.p2os.fake_robot --pty /tmp/ttyFAKE     # prints the device path, Ctrl-C stops
    zenav robot --config robot_side/config/p3at_real.yaml  (with port: /tmp/ttyFAKE)

It echoes SYNC0/SYNC1, answers SYNC2 with name / class / subclass, streams standard SIPs every
``sip_period`` after OPEN (15-bit wrapping x/y counters, absolute heading, wheel velocities, battery,
motors-enabled flag), obeys ENABLE / VEL / RVEL / VEL2 / STOP / PULSE / CLOSE, integrates a unicycle
and stops by itself when no packet arrives for ``watchdog`` seconds (as the robot does).
"""

from __future__ import annotations

import math
import os
import select
import threading
import time
from typing import Any

from robot_side.fake_device import open_raw_pty, serve_until_signal
from robot_side.p2os import protocol as P
from robot_side.p2os.sip import MODELS, Sip, encode_sip, theta_to_raw


class FdPort:
    """A minimal pyserial-like port over a file descriptor (the master side of a pty)."""

    def __init__(self, fd: int, timeout: float = 0.02) -> None:
        self.fd, self.timeout = fd, timeout

    def read(self, size: int = 1) -> bytes:
        r, _, _ = select.select([self.fd], [], [], self.timeout)
        if not r:
            return b""
        try:
            return os.read(self.fd, max(size, 4096))
        except OSError:  # EIO: no process has the other side open
            time.sleep(self.timeout)
            return b""

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            n = os.write(self.fd, view)
            view = view[n:]
        return len(data)

    def close(self) -> None:
        os.close(self.fd)


class FakeP2OSRobot:
    def __init__(self, port: Any, subclass: str = "p3at", name: str = "zenav-fake", sip_period: float = 0.1,
                 start_mm: tuple[float, float] = (0.0, 0.0), start_theta: float = 0.0,
                 battery_v: float = 12.6, answer_sync: bool = True, watchdog: float = 2.0,
                 drop_echoes: tuple[int, ...] = ()) -> None:
        self.port, self.subclass, self.name = port, subclass, name
        self.model = MODELS[subclass]
        self.sip_period, self.answer_sync, self.watchdog = sip_period, answer_sync, watchdog
        self.x_mm, self.y_mm = start_mm
        self.theta = start_theta
        self.battery_v = battery_v
        self.stalled = (False, False)
        self.bumpers = (0, 0)  # (front, rear) pressed-segment bits, segment i in bit i (SIP bits 1-7)
        self.vel_mm_s = 0.0  # commanded, as received (VEL / VEL2)
        self.rvel_deg_s = 0.0  # commanded, as received (RVEL / VEL2)
        self.motors_enabled = False
        self.sync_step = 0  # next SYNC expected
        self.drop_echoes = list(drop_echoes)  # SYNC numbers whose next echo is lost on the line
        self.opened = False
        self.sonar_on = False
        self.sonar_mm: dict[int, float] = {}  # sonar number -> range (mm) sent in each SIP while sonar is on
        # (monotonic time, command, argument) of every command once synchronised
        self.received: list[tuple[float, int, int | bytes | None]] = []
        self.sips_sent = 0
        self.parser = P.PacketParser()
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._slave_fd: int | None = None  # on_pty: the slave end, kept open
        self._link: str | None = None  # on_pty: a symlink to the pty
        self._last_rx = self._last_step = time.monotonic()
        self._next_sip = 0.0

    @classmethod
    def on_pty(cls, link: str | None = None, **kw) -> tuple[FakeP2OSRobot, str]:
        """A robot on a new pty pair; returns it (not started) and the device path for the driver."""
        master, slave, path = open_raw_pty(link)
        robot = cls(FdPort(master), **kw)
        robot._slave_fd = slave  # kept open: the master side reads EIO once every slave fd is closed
        robot._link = link or None
        return robot, path

    # ------------------------------------------------------------------ thread
    def start(self) -> FakeP2OSRobot:
        self._thread = threading.Thread(target=self._run, name="fake-p2os", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        self.port.close()
        if self._slave_fd is not None:
            os.close(self._slave_fd)
        if self._link and os.path.islink(self._link):
            os.unlink(self._link)

    def _run(self) -> None:
        while not self._stop.is_set():
            data = self.port.read(4096)
            now = time.monotonic()
            for body in self.parser.feed(data) if data else ():
                self._last_rx = now
                self._on_packet(body)
            with self.lock:
                self._step(now)
                due = self.opened and now >= self._next_sip
            if due:
                self._next_sip = max(self._next_sip + self.sip_period, now)
                self.port.write(P.frame(encode_sip(self.sip())))
                self.sips_sent += 1

    # ------------------------------------------------------------------ protocol
    def _on_packet(self, body: bytes) -> None:
        try:
            cmd, arg = P.decode_command(body)
        except P.ProtocolError:
            return
        if not self.opened and self.sync_step < 3:
            if cmd == self.sync_step and cmd in self.drop_echoes:
                self.drop_echoes.remove(cmd)
                self.sync_step += 1  # the robot moved on, the client never heard it
            elif cmd == self.sync_step and self.answer_sync:
                reply = bytes([cmd])
                if cmd == 2:
                    reply += b"\0".join(s.encode() for s in (self.name, "Pioneer", self.subclass)) + b"\0"
                self.port.write(P.frame(reply))
                self.sync_step += 1
            elif cmd == 0 and self.answer_sync:  # a new handshake from the start
                self.port.write(P.frame(b"\0"))
                self.sync_step = 1
            else:  # out of order (e.g. CLOSE): not synchronised any more
                self.sync_step = 0
            return
        with self.lock:
            self.received.append((time.monotonic(), cmd, arg))
            self._command(cmd, arg)

    def _command(self, cmd: int, arg: int | bytes | None) -> None:
        n = arg if isinstance(arg, int) else 0
        if cmd == P.Command.OPEN:
            self.opened = True
        elif cmd == P.Command.CLOSE:
            self.opened, self.sync_step = False, 0
            self.vel_mm_s = self.rvel_deg_s = 0.0
        elif cmd == P.Command.ENABLE:
            self.motors_enabled = bool(n)
        elif cmd == P.Command.VEL:
            self.vel_mm_s = float(max(-self.model.max_vel_mm_s, min(self.model.max_vel_mm_s, n)))
        elif cmd == P.Command.RVEL:
            self.rvel_deg_s = float(max(-self.model.max_rvel_deg_s, min(self.model.max_rvel_deg_s, n)))
        elif cmd == P.Command.VEL2:
            def s8(b: int) -> int:
                return b - 256 if b > 127 else b
            div = self.model.vel2_divisor
            right, left = s8((n >> 8) & 0xFF) * div, s8(n & 0xFF) * div
            self.vel_mm_s = (left + right) / 2.0
            self.rvel_deg_s = math.degrees((right - left) / 2.0 * self.model.diff_conv_factor)
        elif cmd == P.Command.STOP:
            self.vel_mm_s = self.rvel_deg_s = 0.0
        elif cmd == P.Command.SONAR:
            self.sonar_on = bool(n)

    # ------------------------------------------------------------------ physics
    def actual(self) -> tuple[float, float]:
        """Actual (v mm/s, w rad/s): zero with motors disabled, closed or after the watchdog."""
        if not (self.opened and self.motors_enabled) or time.monotonic() - self._last_rx > self.watchdog:
            return 0.0, 0.0
        return self.vel_mm_s, math.radians(self.rvel_deg_s)

    def _step(self, now: float) -> None:
        dt, self._last_step = now - self._last_step, now
        v, w = self.actual()
        th = self.theta + w * dt / 2.0  # midpoint heading
        self.x_mm += v * dt * math.cos(th)
        self.y_mm += v * dt * math.sin(th)
        self.theta = math.remainder(self.theta + w * dt, 2 * math.pi)

    def sip(self) -> Sip:
        m = self.model
        v, w = self.actual()
        half_diff = w / m.diff_conv_factor  # (r - l)/2 in mm/s
        left, right = (v - half_diff) / m.vel_conv_factor, (v + half_diff) / m.vel_conv_factor
        flags = (0x01 if self.motors_enabled else 0) | (0x1E if self.sonar_on else 0)
        return Sip(status=0x33 if (v or w) else 0x32,
                   x_raw=round(self.x_mm / m.dist_conv_factor) & 0x7FFF,
                   y_raw=round(self.y_mm / m.dist_conv_factor) & 0x7FFF,
                   th_raw=theta_to_raw(self.theta, m), lvel_raw=round(left), rvel_raw=round(right),
                   battery_dv=round(self.battery_v * 10),
                   stall_bump_left=int(self.stalled[0]) | self.bumpers[1] << 1,
                   stall_bump_right=int(self.stalled[1]) | self.bumpers[0] << 1,
                   control=theta_to_raw(self.theta, m), flags=flags,
                   sonars=tuple((i, round(mm / m.range_conv_factor)) for i, mm in sorted(self.sonar_mm.items()))
                   if self.sonar_on else ())

    def commands(self, cmd: int) -> list[tuple[float, int | bytes | None]]:
        """(time, argument) of every ``cmd`` received so far."""
        with self.lock:
            return [(t, a) for t, c, a in self.received if c == cmd]

    @property
    def pose_m(self) -> tuple[float, float, float]:
        with self.lock:
            return self.x_mm / 1000.0, self.y_mm / 1000.0, self.theta


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m robot_side.p2os.fake_robot",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--pty", metavar="LINK", help="also make LINK a symlink to the device (/tmp/ttyFAKE)")
    ap.add_argument("--subclass", default="p3at", choices=sorted(MODELS), help="robot subclass to report")
    ap.add_argument("--sip-period", type=float, default=0.1, help="seconds between SIPs (10 Hz)")
    ap.add_argument("--battery", type=float, default=12.6, help="battery voltage to report")
    args = ap.parse_args(argv)
    robot, path = FakeP2OSRobot.on_pty(args.pty, subclass=args.subclass, sip_period=args.sip_period,
                                       battery_v=args.battery)
    print(f"{args.pty} -> {path}" if args.pty else path, flush=True)
    return serve_until_signal(robot)


if __name__ == "__main__":
    raise SystemExit(main())
