"""Hokuyo SCIP 2.0 (pure): command encoding, reply parsing with per-line SUM checks, 2/3/4-character
decoding, VV / PP / II parsing, scan -> LaserScan and sensor-clock -> host-clock stamping.

A reply is ``<echo>LF <status><sum>LF [<data><sum>LF]... LF`` (two LFs end it). The sum of a line is the
low 6 bits of the byte sum of its payload plus 0x30. Status "00" is success, "99" means scan data follows
(MD/MS/ME stream); anything else is an error code. Values are 6-bit characters offset by 0x30, most
significant first (2 chars: 12 bits, 3 chars: 18 bits, 4 chars: the 24-bit millisecond timestamp).
Sources and the facts taken from each: docs/hokuyo-scip.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.messages import Header, LaserScan
from robot_side.lasers.scip_clock import WRAP_MS, ClockSync  # noqa: F401 - re-exported: one import for the driver

LF = b"\n"
ERROR_CODE_MAX_MM = 19  # readings 0..19 mm are the sensor's error codes, not distances

STATUS_MEANING = {
    "0A": "unable to create the reply internally", "0B": "buffer shortage / command already processed",
    "0C": "insufficient parameters", "0D": "undefined command", "0E": "undefined command",
    "0F": "insufficient parameters", "0G": "string characters longer than 16",
    "0H": "invalid string characters", "0I": "sensor in firmware update mode", "10": "laser is off",
}


class ScipError(ValueError):
    """A reply that cannot be parsed."""


class ChecksumError(ScipError):
    """A line whose SUM character does not match its bytes."""


class StatusError(ScipError):
    """The sensor answered a command with an error status."""

    def __init__(self, command: str, code: str) -> None:
        self.command, self.code = command, code
        why = STATUS_MEANING.get(code) or ("hardware trouble (laser / motor)" if "50" <= code <= "97" else "")
        super().__init__(f"{command} answered status {code}" + (f" ({why})" if why else ""))


def checksum(payload: bytes) -> int:
    """The SUM character of a line: low 6 bits of the byte sum, plus 0x30."""
    return (sum(payload) & 0x3F) + 0x30


def decode(chars: bytes) -> int:
    """One value of any width: 6 bits per character, offset 0x30, most significant first."""
    v = 0
    for c in chars:
        v = (v << 6) | ((c - 0x30) & 0x3F)
    return v


def decode_array(data: bytes | np.ndarray, width: int) -> np.ndarray:
    """Every ``width``-character value of ``data`` (int64), vectorised."""
    a = np.frombuffer(data, np.uint8) if isinstance(data, (bytes, bytearray, memoryview)) else data
    if len(a) % width:
        raise ScipError(f"{len(a)} data characters are not a multiple of {width}")
    d = (a.reshape(-1, width).astype(np.int64) - 0x30) & 0x3F
    out = d[:, 0].copy()
    for k in range(1, width):
        out = (out << 6) | d[:, k]
    return out


# ---------------------------------------------------------------------- commands
def command(symbol: str, params: str = "", tag: str = "") -> bytes:
    """``symbol params [;tag] LF``; ``tag`` (<= 16 chars) is echoed back by the sensor."""
    return (symbol + params + (";" + tag if tag else "") + "\n").encode("ascii")


def capture_symbol(continuous: bool, chars: int = 3, intensity: bool = False) -> str:
    if intensity:
        return "ME" if continuous else "GE"
    if chars not in (2, 3):
        raise ValueError("range encoding is 2 or 3 characters")
    return ("M" if continuous else "G") + ("D" if chars == 3 else "S")


def md(start: int, end: int, cluster: int = 1, skip: int = 0, scans: int = 0, chars: int = 3,
       intensity: bool = False) -> bytes:
    """Continuous capture MD (3 chars) / MS (2 chars) / ME (range + intensity); scans 0 = until QT."""
    return command(capture_symbol(True, chars, intensity), f"{start:04d}{end:04d}{cluster:02d}{skip:01d}{scans:02d}")


def gd(start: int, end: int, cluster: int = 1, chars: int = 3, intensity: bool = False) -> bytes:
    """Single scan GD / GS / GE (the laser must be on: BM)."""
    return command(capture_symbol(False, chars, intensity), f"{start:04d}{end:04d}{cluster:02d}")


def tm(code: int) -> bytes:
    """TM0 enter time-adjust mode, TM1 read the sensor clock, TM2 leave it."""
    return command("TM", str(code))


# ---------------------------------------------------------------------- replies
@dataclass(frozen=True)
class Reply:
    echo: bytes  # the command as the sensor echoed it (without LF)
    status: str
    lines: list[bytes]  # data lines, SUM character checked and removed

    @property
    def symbol(self) -> str:
        return self.echo[:2].decode("ascii", "replace")


def _status(line: bytes, symbol: str) -> str:
    if len(line) == 3 and checksum(line[:2]) != line[2]:
        raise ChecksumError(f"{symbol}: status line {line!r} fails its checksum")
    if len(line) not in (2, 3):
        raise ScipError(f"{symbol}: bad status line {line!r}")
    return line[:2].decode("ascii", "replace")


def parse_reply(block: bytes, ok: tuple[str, ...] = ("00",)) -> Reply:
    """A command reply (``block`` up to, not including, the empty line). A status not in ``ok`` raises
    StatusError; a line whose SUM fails raises ChecksumError. For ``KEY:value;`` lines (VV / PP / II)
    the sum covers the text before ';' (some firmware includes the ';': accepted too)."""
    parts = block.rstrip(LF).split(LF)
    if len(parts) < 2:
        raise ScipError(f"reply too short: {block[:40]!r}")
    symbol = parts[0][:2].decode("ascii", "replace")
    status = _status(parts[1], symbol)
    if status not in ok:
        raise StatusError(symbol, status)
    lines = []
    for i, line in enumerate(parts[2:]):
        if len(line) < 2:
            raise ScipError(f"{symbol}: empty data line {i}")
        body, s = line[:-1], line[-1]
        if checksum(body) != s and not (body.endswith(b";") and checksum(body[:-1]) == s):
            raise ChecksumError(f"{symbol}: data line {i} fails its checksum")
        lines.append(body)
    return Reply(parts[0], status, lines)


def parse_info(reply: Reply) -> dict[str, str]:
    """``KEY:value;`` lines of VV / PP / II -> {KEY: value}."""
    out = {}
    for line in reply.lines:
        key, _, value = line.decode("ascii", "replace").partition(":")
        out[key.strip()] = value.rstrip(";").strip()
    return out


@dataclass(frozen=True)
class SensorParams:
    """PP: distances in mm, steps (ARES per turn; AMIN..AMAX measurable; AFRT straight ahead), rpm."""

    model: str = "URG-04LX"
    dmin_mm: int = 20
    dmax_mm: int = 5600
    ares: int = 1024
    amin: int = 44
    amax: int = 725
    afrt: int = 384
    scan_rpm: int = 600

    @classmethod
    def from_pp(cls, info: dict[str, str]) -> SensorParams:
        def num(key: str) -> int:
            try:
                return int(info[key].split()[0])
            except (KeyError, ValueError, IndexError) as e:
                raise ScipError(f"PP reply without a numeric {key}: {info.get(key)!r}") from e
        return cls(info.get("MODL", "?"), num("DMIN"), num("DMAX"), num("ARES"), num("AMIN"), num("AMAX"),
                   num("AFRT"), num("SCAN"))

    @property
    def step_angle(self) -> float:
        return 2.0 * math.pi / self.ares

    @property
    def scan_period(self) -> float:
        return 60.0 / self.scan_rpm

    def angle(self, step: int) -> float:
        return (step - self.afrt) * self.step_angle

    def steps_for(self, angle_min: float, angle_max: float) -> tuple[int, int]:
        """First and last step inside [angle_min, angle_max], clipped to AMIN..AMAX."""
        lo = max(self.amin, math.ceil(angle_min / self.step_angle + self.afrt - 1e-9))
        hi = min(self.amax, math.floor(angle_max / self.step_angle + self.afrt + 1e-9))
        if hi <= lo:
            raise ValueError(f"angle_min {angle_min:g} .. angle_max {angle_max:g} rad leaves no steps of the "
                             f"sensor's {self.angle(self.amin):.3f} .. {self.angle(self.amax):.3f} rad")
        return lo, hi


@dataclass(frozen=True)
class ScanData:
    symbol: str  # MD / MS / ME / GD / GS / GE
    start: int
    end: int
    cluster: int
    skip: int
    timestamp_ms: int  # the sensor's 24-bit millisecond counter
    ranges_mm: np.ndarray  # int64, one per cluster
    intensities: np.ndarray | None


def _data_lines(buf: np.ndarray) -> np.ndarray:
    """Checked payload bytes of consecutive ``<payload><sum>LF`` lines (vectorised SUM check)."""
    ends = np.flatnonzero(buf == 0x0A)
    if len(ends) == 0 or ends[-1] != len(buf) - 1:
        raise ScipError("scan data does not end with LF")
    starts = np.concatenate(([0], ends[:-1] + 1))
    if np.any(ends - starts < 2):
        raise ScipError("empty scan data line")
    cs = np.concatenate(([0], np.cumsum(buf, dtype=np.int64)))
    want = ((cs[ends - 1] - cs[starts]) & 0x3F) + 0x30
    bad = np.flatnonzero(want != buf[ends - 1])
    if len(bad):
        raise ChecksumError(f"scan data line {int(bad[0])} (of {len(ends)}) fails its checksum")
    keep = np.ones(len(buf), bool)
    keep[ends] = False
    keep[ends - 1] = False
    return buf[keep]


def parse_scan(block: bytes) -> ScanData | None:
    """One MD / MS / ME / GD / GS / GE reply (``block`` with or without the final empty line).
    None for the "00" acknowledgement of a continuous capture; StatusError for an error status."""
    head_end = block.find(LF)
    echo = block[:head_end]
    symbol = echo[:2].decode("ascii", "replace")
    if head_end < 0 or symbol not in ("MD", "MS", "ME", "GD", "GS", "GE"):
        raise ScipError(f"not a scan reply: {block[:20]!r}")
    try:
        p = echo.split(b";")[0]
        start, end, cluster = int(p[2:6]), int(p[6:10]), max(1, int(p[10:12]))
        skip = int(p[12:13]) if symbol[0] == "M" else 0
    except ValueError as e:
        raise ScipError(f"bad scan echo {echo!r}") from e
    st_end = block.find(LF, head_end + 1)
    if st_end < 0:
        raise ScipError(f"{symbol}: no status line")
    status = _status(block[head_end + 1:st_end], symbol)
    if symbol[0] == "M" and status == "00":
        return None
    if status != ("99" if symbol[0] == "M" else "00"):
        raise StatusError(symbol, status)
    body = block[st_end + 1:].rstrip(LF) + LF
    ts_line = body[:6]
    if len(ts_line) != 6 or ts_line[5:6] != LF or checksum(ts_line[:4]) != ts_line[4]:
        raise ChecksumError(f"{symbol}: bad timestamp line {ts_line!r}")
    data = _data_lines(np.frombuffer(body, np.uint8)[6:])
    n = (end - start) // cluster + 1
    width = 2 if symbol[1] == "S" else 3
    values = decode_array(data, width)
    per = 2 if symbol[1] == "E" else 1
    if len(values) != n * per:
        raise ScipError(f"{symbol}: {len(values) // per} values for steps {start}..{end} / {cluster} (want {n})")
    if per == 2:
        return ScanData(symbol, start, end, cluster, skip, decode(ts_line[:4]), values[0::2], values[1::2])
    return ScanData(symbol, start, end, cluster, skip, decode(ts_line[:4]), values, None)


def to_laser_scan(scan: ScanData, sensor: SensorParams, stamp: float = 0.0, frame_id: str = "laser",
                  publish_intensity: bool = True) -> LaserScan:
    """LaserScan in SI units; error codes and readings outside [DMIN, DMAX] become +inf. The angle of
    a cluster is the angle of its first step (as urg_c); scan_time counts the skipped rotations."""
    mm = scan.ranges_mm
    r = (mm / 1000.0).astype(np.float32)
    r[(mm <= ERROR_CODE_MAX_MM) | (mm < sensor.dmin_mm) | (mm > sensor.dmax_mm)] = np.inf
    inc = scan.cluster * sensor.step_angle
    a0 = sensor.angle(scan.start)
    inten = (scan.intensities.astype(np.float32) if publish_intensity and scan.intensities is not None
             else np.zeros(0, np.float32))
    return LaserScan(header=Header(stamp, frame_id), angle_min=a0, angle_max=a0 + inc * (len(r) - 1),
                     angle_increment=inc, time_increment=scan.cluster * sensor.scan_period / sensor.ares,
                     scan_time=sensor.scan_period * (scan.skip + 1), range_min=sensor.dmin_mm / 1000.0,
                     range_max=sensor.dmax_mm / 1000.0, ranges=r, intensities=inten)


def decode_scan(raw: bytes, sensor: SensorParams, stamp: float = 0.0, frame_id: str = "laser",
                publish_intensity: bool = True) -> LaserScan:
    """One raw MD / MS / ME (or GD / GS / GE) data reply -> LaserScan (raises ScipError when invalid)."""
    scan = parse_scan(raw)
    if scan is None:
        raise ScipError("a capture acknowledgement carries no scan")
    return to_laser_scan(scan, sensor, stamp, frame_id, publish_intensity)
