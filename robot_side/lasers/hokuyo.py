"""Hokuyo SCIP 2.0 laser driver over a serial port (URG-04LX, USB CDC) or TCP (UST-10LX/20LX): no bus here.

    port = open_transport(params)          # pyserial serial_for_url(serial_port) or a TCP socket
    drv = HokuyoDriver(port, params, on_scan=print)
    info = drv.connect()       # QT, VV, PP, II, [TM0 / TM1 x N / TM2], BM, MD|MS|ME acknowledged
    drv.start()                # reader thread: MD/ME stream -> LaserScan -> on_scan
    drv.close()                # QT, then the port

Bad scans (checksum, error status, malformed) are counted in ``stats`` and dropped; ``error_limit`` of
them in a row, a lost port / closed socket, or ``scan_timeout`` without a scan end the reader with
``error`` set (the node then exits so the agent's respawn reconnects).
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

from common.messages import LaserScan
from robot_side.lasers import scip as S
from robot_side.lasers.hokuyo_params import (  # noqa: F401 - re-exported
    HokuyoError,
    HokuyoParams,
    TcpPort,
    open_transport,
    port_name,
)

log = logging.getLogger("zenav.hokuyo")


@dataclass
class ScanStats:
    scans: int = 0
    bad_checksum: int = 0
    error_status: int = 0
    malformed: int = 0
    garbage_bytes: int = 0
    last_error_code: str = ""


@dataclass(frozen=True)
class SensorInfo:
    version: dict[str, str]  # VV: VEND PROD FIRM PROT SERI
    sensor: S.SensorParams  # PP
    status: dict[str, str]  # II: MODL LASR SCSP MESM SBPS TIME STAT
    start_step: int
    end_step: int


class HokuyoDriver:
    def __init__(self, port: Any, params: HokuyoParams | None = None,
                 on_scan: Callable[[LaserScan], None] | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        params = params or HokuyoParams()
        self.port, self.p, self.on_scan, self.clock = port, params, on_scan, clock
        self.name = port_name(params)
        self.stats = ScanStats()
        self.sync = S.ClockSync()
        self.info: SensorInfo | None = None
        self.error: Exception | None = None
        self.last_scan: LaserScan | None = None
        self._buf = bytearray()
        self._echo = b""
        self._bad_in_row = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    # ------------------------------------------------------------------ replies
    def _blocks(self, timeout: float):
        """Complete replies (up to their empty line) as they arrive, until ``timeout``."""
        deadline = time.monotonic() + timeout
        while True:
            i = self._buf.find(b"\n\n")
            if i >= 0:
                block = bytes(self._buf[:i + 1])
                del self._buf[:i + 2]
                yield block
                continue
            if time.monotonic() >= deadline:
                return
            self._read()

    def _read(self) -> None:
        """What the port has (at least one byte, or nothing after its timeout); CR dropped (CR LF ends)."""
        waiting = getattr(self.port, "in_waiting", None)
        data = self.port.read(max(1, waiting) if waiting is not None else 4096)
        if data:
            self._buf += data.replace(b"\r", b"") if b"\r" in data else data

    def request(self, cmd: bytes, ok: tuple[str, ...] = ("00",)) -> S.Reply:
        """Send ``cmd`` and return its parsed reply (other replies before it, e.g. a stream left running
        by a crashed client, are skipped). Error status -> HokuyoError naming the code."""
        echo = cmd.rstrip(b"\n")
        self.port.write(cmd)
        for block in self._blocks(self.p.reply_timeout):
            i = block.find(echo + b"\n")
            if i < 0:
                continue
            try:
                return S.parse_reply(block[i:], ok)
            except S.StatusError as e:
                raise HokuyoError(f"the Hokuyo on {self.name}: {e}") from None
            except S.ScipError as e:
                raise HokuyoError(f"the Hokuyo on {self.name}: bad reply to {echo.decode()}: {e}") from None
        raise HokuyoError(f"no answer from a Hokuyo (SCIP 2.0) on {self.name}: {echo.decode()} got no reply "
                          f"within {self.p.reply_timeout:g} s. Check the cable / address, that the sensor is "
                          f"powered, and that it speaks SCIP 2.0.")

    # ------------------------------------------------------------------ connect
    def connect(self) -> SensorInfo:
        p = self.p
        with contextlib.suppress(Exception):  # not every port has it; a dead one fails below, by name
            self.port.reset_input_buffer()
        self.request(S.command("QT"), ok=tuple(f"{i:02d}" for i in range(100)))  # stop a left-over stream
        version = S.parse_info(self.request(S.command("VV")))
        try:
            sensor = S.SensorParams.from_pp(S.parse_info(self.request(S.command("PP"))))
        except S.ScipError as e:
            raise HokuyoError(f"the Hokuyo on {self.name}: {e}") from None
        status = S.parse_info(self.request(S.command("II")))
        try:
            start, end = sensor.steps_for(p.angle_min, p.angle_max)
        except ValueError as e:
            raise HokuyoError(f"the Hokuyo on {self.name}: {e}") from None
        if p.calibrate_time:
            self.calibrate_time(p.calibrate_samples)
        self.request(S.command("BM"), ok=("00", "02"))  # 02: already on
        self.info = SensorInfo(version, sensor, status, start, end)
        return self.info

    def calibrate_time(self, n: int) -> float:
        """TM0, ``n`` x TM1 (host send / receive times around each), TM2 -> ClockSync offset."""
        self.request(S.tm(0), ok=("00", "02"))
        samples = []
        try:
            for _ in range(n):
                t0 = self.clock()
                r = self.request(S.tm(1))
                t1 = self.clock()
                if not r.lines or len(r.lines[0]) != 4:
                    raise HokuyoError(f"the Hokuyo on {self.name}: TM1 reply without a 4-character time")
                samples.append((t0, S.decode(r.lines[0]), t1))
        finally:
            self.request(S.tm(2), ok=("00", "03"))
        return self.sync.calibrate(samples)

    def grab(self) -> LaserScan:
        """One scan with GD / GS / GE (before ``start``)."""
        p, info = self.p, self._need_info()
        cmd = S.gd(info.start_step, info.end_step, p.cluster, p.encoding_chars, p.intensity)
        self.port.write(cmd)
        for block in self._blocks(p.reply_timeout):
            i = block.find(cmd.rstrip(b"\n") + b"\n")
            if i >= 0:
                try:
                    return self._to_scan(S.parse_scan(block[i:]), self.clock())
                except S.ScipError as e:
                    raise HokuyoError(f"the Hokuyo on {self.name}: {e}") from None
        raise HokuyoError(f"no answer to {cmd.decode().strip()} from the Hokuyo on {self.name}")

    def _need_info(self) -> SensorInfo:
        if self.info is None:
            raise RuntimeError("connect() first")
        return self.info

    def _to_scan(self, scan: S.ScanData, received: float) -> LaserScan:
        p, sensor = self.p, self._need_info().sensor
        if p.calibrate_time:  # the counter is read at the rear of the rotation (as urg_node assumes)
            rear = (sensor.angle(scan.start) + math.pi) / (2 * math.pi) * sensor.scan_period
            stamp = self.sync.stamp(scan.timestamp_ms, received) + rear
        else:
            stamp = received
        return S.to_laser_scan(scan, sensor, stamp + p.time_offset, p.frame_id, p.publish_intensity)

    # ------------------------------------------------------------------ streaming
    def start(self) -> None:
        p, info = self.p, self._need_info()
        cmd = S.md(info.start_step, info.end_step, p.cluster, p.skip, 0, p.encoding_chars, p.intensity)
        self._echo = cmd.rstrip(b"\n") + b"\n"
        self.request(cmd)  # the "00" acknowledgement; scans follow with "99"
        self._thread = threading.Thread(target=self._run, name="hokuyo:rx", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        last = time.monotonic()
        try:
            while not self._stop.is_set():
                if self._handle_buffered():
                    last = time.monotonic()
                if time.monotonic() - last > self.p.scan_timeout:
                    if not self._drain():
                        raise HokuyoError(f"no scan from the Hokuyo on {self.name} for {self.p.scan_timeout:g} s")
                    last = time.monotonic()
                if self._bad_in_row >= self.p.error_limit:
                    raise HokuyoError(f"{self._bad_in_row} bad scans in a row from the Hokuyo on {self.name} "
                                      f"(last error status {self.stats.last_error_code or 'none'})")
                self._read()
        except Exception as e:  # noqa: BLE001 - a lost port ends the loop; the node reports it
            if not self._stop.is_set():
                self.error = e
                log.error("hokuyo on %s stopped: %s", self.name, e)

    def _drain(self) -> bool:
        """Read what waits in the port and handle its whole replies; True if one was a scan. A process the
        machine did not run for a while wakes with the scans sent meanwhile in the port, and its first read
        returns what was asked for when the port was empty (one byte): they are read before the device is
        judged silent."""
        got = False
        while getattr(self.port, "in_waiting", 0):
            self._read()
            got = self._handle_buffered() or got
        return got

    def _handle_buffered(self) -> bool:
        """Handle the whole replies read so far; True if one was a scan."""
        got = False
        for block in self._blocks(0.0):
            got = self._handle(block) or got
        return got

    def _handle(self, block: bytes) -> bool:
        """One reply of the stream; True for a published scan."""
        st = self.stats
        i = block.find(self._echo)
        if i < 0:
            st.garbage_bytes += len(block) + 2
            return False
        st.garbage_bytes += i
        try:
            scan = S.parse_scan(block[i:])
        except S.StatusError as e:
            st.error_status += 1
            st.last_error_code = e.code
            self._bad_in_row += 1
            log.warning("hokuyo on %s: %s", self.name, e)
            return False
        except S.ChecksumError:
            st.bad_checksum += 1
            self._bad_in_row += 1
            return False
        except S.ScipError:
            st.malformed += 1
            self._bad_in_row += 1
            return False
        if scan is None:
            return False
        self._bad_in_row = 0
        msg = self._to_scan(scan, self.clock())
        st.scans += 1
        self.last_scan = msg
        if self.on_scan is not None:
            try:
                self.on_scan(msg)
            except Exception:  # noqa: BLE001 - a publishing error must not stop the laser
                log.exception("on_scan callback failed")
        return True

    # ------------------------------------------------------------------ shutdown
    def close(self) -> None:
        """Stop the stream (QT: laser off) and close the port (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        try:
            if self.error is None and self.info is not None:
                self.port.write(S.command("QT"))
                with contextlib.suppress(AttributeError):
                    self.port.flush()
        except Exception as e:  # noqa: BLE001 - closing a dead port
            log.warning("could not send QT to the Hokuyo on %s: %s", self.name, e)
        finally:
            with contextlib.suppress(Exception):
                self.port.close()
