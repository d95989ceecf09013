"""A simulated Hokuyo SCIP 2.0 *device* on a pty (like a URG-04LX on USB) or a TCP port (like a UST-10LX),
written from the SCIP 2.0 specification independently of the driver's codec (robot_side/lasers/scip.py):

    python -m robot_side.lasers.fake_hokuyo --pty /tmp/ttyHOKUYO          # serial_port: /tmp/ttyHOKUYO
    python -m robot_side.lasers.fake_hokuyo --tcp 127.0.0.1:10940         # ip_address / ip_port

It answers VV, PP, II, BM, QT, RS, TM0/1/2, MD/MS/ME (continuous) and GD/GS/GE (single) with echo, status
and per-line sums, timestamps from a 24-bit millisecond counter (``time_base_ms`` sets where it starts,
to test the wrap), and ranges of a synthetic room (``range_mm``). Faults: ``inject("checksum")``,
``inject("status", code="50")``, ``inject("garbage", data=b"...")`` (each on the next scan), ``unplug()``
(closes the pty / socket), ``fail={"BM": "01"}`` (a command answered with an error status).
"""

from __future__ import annotations

import threading
import time

import numpy as np

from robot_side.fake_device import serve_until_signal
from robot_side.lasers.fake_hokuyo_room import (
    MODELS,
    cluster_values,
    encode,
    encode_all,
    room_range_mm,
    step_angle,
    sum_char,
    sum_line,
)
from robot_side.lasers.fake_link import FakeDeviceLink


class FakeHokuyo(FakeDeviceLink):
    """The device: a SCIP 2.0 command interpreter and scan streamer on a pty or TCP link (``on_pty`` /
    ``on_tcp``, from ``robot_side.lasers.fake_link``)."""

    def __init__(self, model: str = "URG-04LX", scan_period: float | None = None, time_base_ms: int = 0,
                 fail: dict[str, str] | None = None) -> None:
        super().__init__()
        self.model, self.m = model, MODELS[model]
        self.scan_period = scan_period or 60.0 / self.m["rpm"]
        self.time_base_ms, self.fail = time_base_ms, dict(fail or {})
        self.laser_on = self.tm_mode = False
        self.stream: dict | None = None  # the running MD/MS/ME: echo fields, remaining scans, next time
        self.commands: list[str] = []
        self.scans_sent = 0
        self.unplugged = threading.Event()
        self._faults: list[tuple[str, dict]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._thread: threading.Thread | None = None

    def _client_gone(self) -> None:
        self.stream, self.laser_on = None, False

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> FakeHokuyo:
        self._thread = threading.Thread(target=self._run, name="fake-hokuyo", daemon=True)
        self._thread.start()
        return self

    def unplug(self) -> None:
        """The cable is pulled: the pty / socket is closed, nothing answers any more."""
        self.unplugged.set()
        self.close()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        self._close_link()

    def inject(self, kind: str, **kw) -> None:
        """A fault on the next scan without one: "checksum", "status" (code=...), "garbage" (data=...)."""
        if kind not in ("checksum", "status", "garbage"):
            raise ValueError(kind)
        with self._lock:
            self._faults.append((kind, kw))

    def now_ms(self) -> int:
        return (self.time_base_ms + int((time.monotonic() - self._t0) * 1000.0)) & 0xFFFFFF

    def _run(self) -> None:
        while not self._stop.is_set():
            self._rx += self._recv(0.002)
            while True:
                cut = [i for i in (self._rx.find(b"\n"), self._rx.find(b"\r")) if i >= 0]
                if not cut:
                    break
                line, self._rx = self._rx[:min(cut)], self._rx[min(cut) + 1:]
                if line:
                    self._command(line.decode("ascii", "replace"))
            s = self.stream
            if s is not None and time.monotonic() >= s["next"]:
                s["next"] += self.scan_period * (s["skip"] + 1)
                self._send_scan(s)

    # ------------------------------------------------------------------ the room (fake_hokuyo_room)
    def angle(self, step) -> np.ndarray:
        return step_angle(self.m, step)

    def range_mm(self, step) -> np.ndarray:
        return room_range_mm(self.m, step)

    def values(self, start: int, end: int, cluster: int) -> tuple[np.ndarray, np.ndarray]:
        return cluster_values(self.m, start, end, cluster)

    # ------------------------------------------------------------------ protocol
    def _reply(self, echo: str, status: str, lines: tuple[bytes, ...] = ()) -> None:
        out = echo.encode() + b"\n" + sum_line(status.encode()) + b"".join(lines) + b"\n"
        self._send(out)

    def _info(self, pairs) -> tuple[bytes, ...]:
        # "KEY:value;" + sum of "KEY:value" (the ';' is not summed)
        return tuple(f"{k}:{v}".encode() + b";" + sum_char(f"{k}:{v}".encode()) + b"\n" for k, v in pairs)

    def _command(self, line: str) -> None:
        self.commands.append(line)
        sym, params = line[:2], line[2:].split(";")[0]
        if sym in self.fail:
            return self._reply(line, self.fail[sym])
        m = self.m
        if sym == "VV":
            return self._reply(line, "00", self._info([
                ("VEND", "Hokuyo Automatic Co.,Ltd."), ("PROD", f"SOKUIKI Sensor {self.model} (zenav fake)"),
                ("FIRM", "3.4.03(17/Dec./2012)"), ("PROT", "SCIP 2.0"), ("SERI", "H0000042")]))
        if sym == "PP":
            return self._reply(line, "00", self._info([
                ("MODL", f"{self.model}(Hokuyo Automatic Co.,Ltd.)"), ("DMIN", m["dmin"]), ("DMAX", m["dmax"]),
                ("ARES", m["ares"]), ("AMIN", m["amin"]), ("AMAX", m["amax"]), ("AFRT", m["afrt"]),
                ("SCAN", m["rpm"])]))
        if sym == "II":
            return self._reply(line, "00", self._info([
                ("MODL", self.model), ("LASR", "ON" if self.laser_on else "OFF"), ("SCSP", f"{m['rpm']}[rpm]"),
                ("MESM", "Measuring" if self.stream else "Idle"), ("SBPS", "USB only"),
                ("TIME", f"{self.now_ms():06X}"), ("STAT", "Sensor works well.")]))
        if sym == "BM":
            was, self.laser_on = self.laser_on, True
            return self._reply(line, "02" if was else "00")
        if sym in ("QT", "RS"):
            self.laser_on, self.stream, self.tm_mode = False, None, False
            if sym == "RS":
                self._t0, self.time_base_ms = time.monotonic(), 0
            return self._reply(line, "00")
        if sym == "TM":
            return self._tm(line, params)
        if sym in ("MD", "MS", "ME", "GD", "GS", "GE"):
            return self._capture(line, sym, params)
        return self._reply(line, "0E")

    def _tm(self, line: str, code: str) -> None:
        if code == "0":
            was, self.tm_mode, self.laser_on, self.stream = self.tm_mode, True, False, None
            return self._reply(line, "02" if was else "00")
        if code == "1":
            if not self.tm_mode:
                return self._reply(line, "04")
            return self._reply(line, "00", (sum_line(encode(self.now_ms(), 4)),))
        if code == "2":
            was, self.tm_mode = self.tm_mode, False
            return self._reply(line, "00" if was else "03")
        return self._reply(line, "01")

    def _capture(self, line: str, sym: str, params: str) -> None:
        if sym[1] == "E" and not self.m["intensity"]:
            return self._reply(line, "0E")
        cont = sym[0] == "M"
        fields = [params[0:4], params[4:8], params[8:10]] + ([params[10:11], params[11:13]] if cont else [])
        for code, f in zip(("01", "02", "03", "06", "07"), fields):
            if len(f) == 0 or not f.isdigit():
                return self._reply(line, code)
        start, end, cluster = int(fields[0]), int(fields[1]), max(1, int(fields[2]))
        if end > self.m["amax"]:
            return self._reply(line, "04")
        if end < start:
            return self._reply(line, "05")
        if not cont:
            if not self.laser_on:
                return self._reply(line, "10")
            return self._send(self._scan_block(sym, line, "00", start, end, cluster))
        self.laser_on = True
        self._reply(line, "00")
        self.stream = dict(sym=sym, params=params, tag=line[2 + len(params):], start=start, end=end,
                           cluster=cluster, skip=int(fields[3]), scans=int(fields[4]),
                           remaining=int(fields[4]), next=time.monotonic())
        return None

    def _scan_block(self, sym: str, echo: str, status: str, start: int, end: int, cluster: int) -> bytes:
        r, inten = self.values(start, end, cluster)
        if sym[1] == "S":
            data = encode_all(np.minimum(r, 4095), 2)
        elif sym[1] == "E":
            data = encode_all(np.column_stack([r, inten]).ravel(), 3)
        else:
            data = encode_all(r, 3)
        blocks = b"".join(sum_line(data[i:i + 64]) for i in range(0, len(data), 64))
        return echo.encode() + b"\n" + sum_line(status.encode()) + sum_line(encode(self.now_ms(), 4)) + blocks + b"\n"

    def _send_scan(self, s: dict) -> None:
        p = s["params"]
        if s["scans"]:
            s["remaining"] -= 1
            p = p[:11] + f"{s['remaining']:02d}"
        echo = s["sym"] + p + s["tag"]
        with self._lock:  # one fault per scan, in the order injected
            faults = [self._faults.pop(0)] if self._faults else []
        block = self._scan_block(s["sym"], echo, "99", s["start"], s["end"], s["cluster"])
        for kind, kw in faults:
            if kind == "garbage":
                block = kw.get("data", b"\x00\xffjunk\n") + block
            elif kind == "status":
                block = echo.encode() + b"\n" + sum_line(kw.get("code", "50").encode()) + b"\n"
            elif kind == "checksum":  # one data character changed, its line's sum left as it was
                i = len(block) - 4  # the last data character (then its sum, LF, LF)
                block = block[:i] + bytes([0x30 + ((block[i] - 0x30 + 1) & 0x3F)]) + block[i + 1:]
        self.scans_sent += 1  # counted before the write: the driver may parse it before _send returns
        self._send(block)
        if s["scans"] and s["remaining"] <= 0:
            self.stream, self.laser_on = None, False


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m robot_side.lasers.fake_hokuyo", description=__doc__.split("\n")[0])
    where = ap.add_mutually_exclusive_group(required=True)
    where.add_argument("--pty", metavar="LINK", help="a pty; LINK becomes a symlink to it (/tmp/ttyHOKUYO)")
    where.add_argument("--tcp", metavar="HOST:PORT", help="listen on TCP (127.0.0.1:10940)")
    ap.add_argument("--model", default=None, choices=sorted(MODELS), help="default URG-04LX (pty), UST-10LX (tcp)")
    args = ap.parse_args(argv)
    if args.pty:
        fake, path = FakeHokuyo.on_pty(args.pty, model=args.model or "URG-04LX")
        print(f"{args.pty} -> {path}", flush=True)
    else:
        host, _, port = args.tcp.rpartition(":")
        fake, addr = FakeHokuyo.on_tcp(host or "127.0.0.1", int(port), model=args.model or "UST-10LX")
        print(f"listening on {addr[0]}:{addr[1]}", flush=True)
    return serve_until_signal(fake)


if __name__ == "__main__":
    raise SystemExit(main())
