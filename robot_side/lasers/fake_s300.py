"""A simulated SICK S300 in continuous data output on the far end of a serial port (a pty), for tests and
for trying the driver without a scanner:

    python -m robot_side.lasers.fake_s300 --pty /tmp/ttyS300      # prints the device path, Ctrl-C stops
    zenav robot --config robot_side/config/pioneer_lx_real.yaml  (with the s300 port: /tmp/ttyS300)

It encodes telegrams from the published format (docs/sick-s300.md) with its own encoder and CRC, NOT the
driver's parser: the two implementations check each other. Every ``period`` (40 ms) it sends one distance
telegram of a synthetic rectangular room around the scanner (541 values over 270 degrees, cm, warning /
protective-field bits on near beams, the reflector bit on a few), in the old (1.02) or new (1.03) layout.
Faults on demand: ``inject("corrupt" | "crc" | "garbage")``, ``start_mid_telegram=True`` and
``unplug()`` (closes the pty, as pulling the USB adapter does).
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time

import numpy as np

from robot_side.fake_device import open_raw_pty, serve_until_signal

NO_RETURN_CM = 0x1FFF  # this fake's value for "nothing within max_range" (13 bits all set)
LAYOUTS = ("old", "new", "new_nofield")  # 1.02; 1.03 with a measurement field; 1.03 without one


def crc_ccitt(data: bytes) -> int:
    """CRC-16, polynomial x^16 + x^12 + x^5 + 1, preset 0xFFFF, MSB first (bitwise, on purpose)."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def encode_telegram(words: np.ndarray, scan_number: int, telegram_number: int, layout: str = "new",
                    address: int = 7, field: int = 1, status: int = 0, block: int = 0xBBBB) -> bytes:
    """One continuous-output telegram carrying the 16-bit ``words`` (distance block)."""
    version = b"\x02\x01" if layout == "old" else b"\x03\x01"
    body = (version + status.to_bytes(2, "little") + (scan_number & 0xFFFFFFFF).to_bytes(4, "little")
            + (telegram_number & 0xFFFF).to_bytes(2, "little") + block.to_bytes(2, "little")
            + (field * 0x1111).to_bytes(2, "little") + np.asarray(words, dtype="<u2").tobytes())
    total = 10 + len(body) + 2
    counted = {"old": total - 4, "new": total - 14, "new_nofield": total - 8}[layout]
    head = bytes(6) + (counted // 2).to_bytes(2, "big") + bytes([0xFF, address])
    crc = crc_ccitt(head[4:] + body)
    return head + body + crc.to_bytes(2, "little")


def room_ranges(angles: np.ndarray, room: tuple[float, float, float, float]) -> np.ndarray:
    """Distance (m) from the origin along each angle to the walls x = x_min / x_max, y = y_min / y_max
    (a wall at +-inf is open)."""
    x_min, x_max, y_min, y_max = room
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 1e-12, x_max / c, np.where(c < -1e-12, x_min / c, np.inf))
        ty = np.where(s > 1e-12, y_max / s, np.where(s < -1e-12, y_min / s, np.inf))
    return np.minimum(tx, ty)


class FakeS300:
    def __init__(self, fd: int, room: tuple[float, float, float, float] = (-2.0, 4.0, -3.0, math.inf),
                 period: float = 0.04, layout: str = "new", address: int = 7, field: int = 1,
                 values: int = 541, fov_deg: float = 270.0, max_range: float = 29.96,
                 start_mid_telegram: bool = False) -> None:
        if layout not in LAYOUTS:
            raise ValueError(f"layout {layout!r} not in {LAYOUTS}")
        self.fd, self.room, self.period, self.layout = fd, room, period, layout
        self.address, self.field, self.max_range = address, field, max_range
        half = math.radians(fov_deg) / 2.0
        self.angles = np.linspace(-half, half, values)
        self.start_mid_telegram = start_mid_telegram
        self.scans_sent = 0
        self.bytes_dropped = 0  # not written: the pty buffer was full (nobody reading)
        self.unplugged = False
        self.lock = threading.Lock()
        self._faults: list[tuple[str, int]] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._slave_fd: int | None = None
        self._link: str | None = None

    @classmethod
    def on_pty(cls, link: str | None = None, **kw) -> tuple[FakeS300, str]:
        """A scanner on a new pty pair; returns it (not started) and the device path for the driver."""
        master, slave, path = open_raw_pty(link)
        os.set_blocking(master, False)  # a scanner never waits for its reader: unread bytes are lost
        fake = cls(master, **kw)
        fake._slave_fd = slave  # kept open, so the master never reads EIO before the driver connects
        fake._link = link or None
        return fake, path

    # ------------------------------------------------------------------ what it measures
    def true_ranges(self) -> np.ndarray:
        """The room's exact distances (m) per beam, +inf beyond max_range."""
        r = room_ranges(self.angles, self.room)
        return np.where(r <= self.max_range, r, np.inf)

    def words(self) -> np.ndarray:
        r = self.true_ranges()
        cm = np.where(np.isfinite(r), np.round(np.nan_to_num(r, posinf=0.0) * 100.0), NO_RETURN_CM)
        w = np.minimum(cm, NO_RETURN_CM).astype(np.uint16)
        w[r < 2.0] |= 0x8000  # warning field infringed
        w[r < 1.0] |= 0x4000  # protective field infringed
        w[::50] |= 0x2000  # reflector marks
        return w

    def telegram(self, n: int) -> bytes:
        return encode_telegram(self.words(), scan_number=n, telegram_number=n, layout=self.layout,
                               address=self.address, field=self.field)

    # ------------------------------------------------------------------ faults
    def inject(self, fault: str, n: int = 1) -> None:
        """Next telegram: "corrupt" (cut short, the next one follows at once), "crc" (wrong CRC) or
        "garbage" (``n`` random non-zero bytes sent before it)."""
        if fault not in ("corrupt", "crc", "garbage"):
            raise ValueError(fault)
        with self.lock:
            self._faults.append((fault, n))

    def _apply_faults(self, data: bytes) -> bytes:
        with self.lock:
            faults, self._faults = self._faults, []
        for fault, n in faults:
            if fault == "corrupt":
                data = data[: len(data) // 2]
            elif fault == "crc":
                data = data[:-2] + bytes([data[-2] ^ 0x5A, data[-1]])
            else:
                data = np.random.default_rng(self.scans_sent).integers(1, 256, n, dtype=np.uint8).tobytes() + data
        return data

    # ------------------------------------------------------------------ thread
    def start(self) -> FakeS300:
        self._thread = threading.Thread(target=self._run, name="fake-s300", daemon=True)
        self._thread.start()
        return self

    def _write(self, data: bytes) -> None:
        try:
            n = os.write(self.fd, data)
        except BlockingIOError:
            n = 0
        except OSError:
            return
        self.bytes_dropped += len(data) - n

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            data = self._apply_faults(self.telegram(self.scans_sent))
            if self.start_mid_telegram and self.scans_sent == 0:
                data = data[len(data) // 3:]
            self._write(data)
            self.scans_sent += 1
            next_t = max(next_t + self.period, time.monotonic() - self.period)
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def unplug(self) -> None:
        """Stop streaming and close both ends of the pty: the driver's next read fails."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        if not self.unplugged:
            self.unplugged = True
            for fd in (self.fd, self._slave_fd):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            if self._link and os.path.islink(self._link):
                os.unlink(self._link)

    close = unplug


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m robot_side.lasers.fake_s300", description=__doc__.split("\n")[0])
    ap.add_argument("--pty", metavar="LINK", help="also make LINK a symlink to the device (/tmp/ttyS300)")
    ap.add_argument("--layout", default="new", choices=LAYOUTS, help="telegram layout (protocol 1.02 / 1.03)")
    ap.add_argument("--period", type=float, default=0.04, help="seconds between scans (S300: 40 ms)")
    ap.add_argument("--address", type=int, default=7, help="device address (ROS scan_id)")
    ap.add_argument("--room", type=float, nargs=4, metavar=("XMIN", "XMAX", "YMIN", "YMAX"),
                    default=(-2.0, 4.0, -3.0, math.inf), help="walls around the scanner (m; inf = open)")
    args = ap.parse_args(argv)
    fake, path = FakeS300.on_pty(args.pty, layout=args.layout, period=args.period, address=args.address,
                                 room=tuple(args.room))
    print(f"{args.pty} -> {path}" if args.pty else path, flush=True)
    return serve_until_signal(fake)


if __name__ == "__main__":
    raise SystemExit(main())
