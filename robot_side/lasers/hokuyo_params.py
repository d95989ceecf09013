"""Hokuyo parameters (urg_node names) and the transports the driver reads from: a pyserial port or TCP."""

from __future__ import annotations

import array
import fcntl
import math
import socket
import termios
from dataclasses import dataclass
from typing import Any

from common.config import param


@dataclass(frozen=True)
class HokuyoParams:
    """urg_node parameter names (ROS 1; ROS 2 spellings as aliases) plus the zenav extras."""

    ip_address: str = param("", doc="sensor IP (UST-10LX/20LX over TCP); empty: use serial_port")
    ip_port: int = param(10940, lo=1, hi=65535, doc="sensor TCP port")
    serial_port: str = param("/dev/ttyACM0", doc="serial device or pyserial URL (URG-04LX over USB)")
    serial_baud: int = param(115200, choices=(19200, 38400, 57600, 115200, 250000, 500000, 750000),
                             doc="baud rate (no effect on USB CDC devices)")
    frame_id: str = param("laser", aliases=("laser_frame_id",), doc="frame of the scan")
    topic: str = param("scan", doc="bus topic of the LaserScan")
    angle_min: float = param(-math.pi, lo=-math.pi, hi=math.pi, unit="rad", doc="crop: first beam angle")
    angle_max: float = param(math.pi, lo=-math.pi, hi=math.pi, unit="rad", doc="crop: last beam angle")
    cluster: int = param(1, lo=1, hi=99, doc="adjacent steps merged into one beam (the sensor keeps the nearest)")
    skip: int = param(0, lo=0, hi=9, doc="rotations skipped between published scans")
    intensity: bool = param(False, doc="capture range + intensity (ME) instead of range only (MD / MS)")
    publish_intensity: bool = param(True, doc="put captured intensities in the LaserScan")
    encoding_chars: int = param(3, choices=(2, 3), doc="range encoding: 3 chars (MD) or 2 chars (MS, <= 4.095 m)")
    time_offset: float = param(0.0, lo=-10.0, hi=10.0, unit="s", aliases=("default_user_latency",),
                               doc="added to every stamp")
    calibrate_time: bool = param(True, doc="stamp from the sensor clock synchronised with TM0/TM1/TM2 "
                                           "(false: the host time the scan arrived)")
    calibrate_samples: int = param(10, lo=1, hi=200, doc="TM1 round trips when calibrating")
    error_limit: int = param(4, lo=1, hi=10000, doc="bad scans in a row before giving up (reconnect)")
    reply_timeout: float = param(2.0, lo=0.05, hi=60.0, unit="s", doc="wait for each command reply")
    scan_timeout: float = param(1.0, lo=0.05, hi=60.0, unit="s", doc="no scan for this long: connection lost")


class HokuyoError(RuntimeError):
    """No (valid) answer from the sensor, an error status, or a lost connection."""


class TcpPort:
    """The part of a pyserial port the driver uses, over a TCP socket; a closed socket raises."""

    def __init__(self, host: str, port: int, timeout: float = 0.05, connect_timeout: float = 2.0) -> None:
        self.name = f"{host}:{port}"
        try:
            self.sock = socket.create_connection((host, port), timeout=connect_timeout)
        except OSError as e:
            raise HokuyoError(f"cannot connect to the Hokuyo at {self.name}: {e}") from e
        self.sock.settimeout(timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def read(self, size: int = 4096) -> bytes:
        try:
            data = self.sock.recv(max(size, 4096))
        except (socket.timeout, BlockingIOError):
            return b""
        if not data:
            raise ConnectionError(f"the Hokuyo at {self.name} closed the connection")
        return data

    @property
    def in_waiting(self) -> int:
        """Bytes received and not yet read (pyserial's name)."""
        buf = array.array("i", [0])
        fcntl.ioctl(self.sock.fileno(), termios.FIONREAD, buf)
        return buf[0]

    def write(self, data: bytes) -> int:
        self.sock.sendall(data)
        return len(data)

    def close(self) -> None:
        self.sock.close()


def open_transport(p: HokuyoParams) -> Any:
    if p.ip_address:
        return TcpPort(p.ip_address, p.ip_port, connect_timeout=p.reply_timeout)
    import serial

    try:
        return serial.serial_for_url(p.serial_port, baudrate=p.serial_baud, timeout=0.05, write_timeout=2.0)
    except (serial.SerialException, ValueError, OSError) as e:
        raise HokuyoError(f"cannot open the Hokuyo's serial port {p.serial_port!r}: {e}") from e


def port_name(p: HokuyoParams) -> str:
    return f"{p.ip_address}:{p.ip_port}" if p.ip_address else p.serial_port
