"""SICK S300 driver over any pyserial-like port (``read``/``close``, optional ``in_waiting``): no bus here.

    port = open_port("/dev/ttyUSB0", 500000)        # or "socket://host:port", a pty path
    drv = S300Driver(port, S300Params(), on_scan=print, clock=time.time)
    drv.start()           # reader thread: bytes -> TelegramStream (resync, CRC) -> LaserScan -> on_scan
    drv.stats()           # {"telegrams": .., "scans": .., "crc_errors": .., "garbage_bytes": .., ...}
    drv.error             # the exception that ended the reader (a lost port), else None
    drv.close()

The scanner streams by itself (continuous data output): nothing is ever written to it.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import Any, Callable

from common.messages import LaserScan
from robot_side.lasers.s300 import S300Params, Telegram, TelegramError, TelegramStream, scan_from_telegram

log = logging.getLogger("zenav.s300")


class S300ConnectionError(RuntimeError):
    """The scanner's serial port cannot be opened."""


def open_port(url: str, baud: int = 500000, timeout: float = 0.02) -> Any:
    """A pyserial port for a device path or URL; an error names the port."""
    import serial

    try:
        port = serial.serial_for_url(url, baudrate=baud, timeout=timeout)
    except (serial.SerialException, ValueError, OSError) as e:
        raise S300ConnectionError(f"cannot open the S300's serial port {url!r}: {e}") from e
    with contextlib.suppress(Exception):
        port.reset_input_buffer()  # old bytes: the reader would only resynchronise past them
    return port


class S300Driver:
    def __init__(self, port: Any, params: S300Params | None = None,
                 on_scan: Callable[[LaserScan], None] | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        self.port, self.p, self.on_scan, self.clock = port, params or S300Params(), on_scan, clock
        self.stream = TelegramStream()
        self.error: Exception | None = None
        self.scans = 0  # published
        self.standby = 0  # distance telegrams of a scanner in standby (all values 0x4004): not published
        self.other_address = 0  # telegrams of another device address than scan_id
        self.unusable = 0  # good telegrams without a scan: I/O or reflector blocks, unconfigured fields
        self.last_telegram = clock()  # clock time of the last good telegram (start: of the driver)
        self.last_scan: LaserScan | None = None
        self._addresses_seen: set[int] = set()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    # ------------------------------------------------------------------ counters
    @property
    def telegrams(self) -> int:
        return self.stream.telegrams

    @property
    def crc_errors(self) -> int:
        return self.stream.crc_errors

    @property
    def garbage_bytes(self) -> int:
        return self.stream.garbage_bytes

    def stats(self) -> dict[str, int]:
        return {"telegrams": self.telegrams, "scans": self.scans, "crc_errors": self.crc_errors,
                "garbage_bytes": self.garbage_bytes, "standby": self.standby,
                "other_address": self.other_address, "unusable": self.unusable}

    # ------------------------------------------------------------------ reading
    def feed(self, data: bytes, received: float) -> list[LaserScan]:
        """Bytes from the port (``received``: clock time they arrived) -> the scans they complete."""
        before = self.crc_errors
        out = []
        for t in self.stream.feed(data):
            scan = self._handle(t, received)
            if scan is not None:
                out.append(scan)
        if self.crc_errors != before and self.p.debug:
            log.info("S300 on %s: %d telegram(s) failed the CRC (%d so far)", self.p.port,
                     self.crc_errors - before, self.crc_errors)
        return out

    def _handle(self, t: Telegram, received: float) -> LaserScan | None:
        p = self.p
        if p.debug:
            log.info("S300 telegram: version %04X address %d status %04X scan %d telegram %d block %04X "
                     "field %d, %d values", t.version, t.address, t.status, t.scan_number, t.telegram_number,
                     t.block, t.field, t.values.size)
        if t.address != p.scan_id:
            self.other_address += 1
            if t.address not in self._addresses_seen:
                self._addresses_seen.add(t.address)
                log.warning("S300 on %s: telegrams from device address %d ignored (scan_id is %d)",
                            p.port, t.address, p.scan_id)
            return None
        self.last_telegram = received
        if not t.is_distance:
            self.unusable += 1
            return None
        if t.in_standby:
            self.standby += 1
            if self.standby == 1 or self.standby % 250 == 0:
                log.warning("S300 on %s is in standby (%d scans): no scan published", p.port, self.standby)
            return None
        try:
            scan = scan_from_telegram(t, p, received)
        except TelegramError as e:
            self.unusable += 1
            if self.unusable == 1 or p.debug:
                log.warning("S300 on %s: telegram not usable: %s", p.port, e)
            return None
        self.scans += 1
        self.last_scan = scan
        return scan

    def read_once(self) -> list[LaserScan]:
        """One read from the port (up to its timeout); raises what the port raises."""
        n = max(1, getattr(self.port, "in_waiting", 0) or 0)
        data = self.port.read(n)
        return self.feed(data, self.clock()) if data else []

    # ------------------------------------------------------------------ thread
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="s300:reader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                for scan in self.read_once():
                    if self.on_scan is not None:
                        try:
                            self.on_scan(scan)
                        except Exception:  # noqa: BLE001 - a publishing error must not stop the reader
                            log.exception("on_scan callback failed")
        except Exception as e:  # noqa: BLE001 - a lost port ends the loop; the node reports it
            if not self._stop.is_set():
                self.error = e
                log.error("S300 reader on %s stopped: %s", self.p.port, e)

    def silent_for(self) -> float:
        """Seconds since the last good telegram from our scanner (or since the start)."""
        return self.clock() - self.last_telegram

    def close(self) -> None:
        """Stop the reader and close the port (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        with contextlib.suppress(Exception):
            self.port.close()
