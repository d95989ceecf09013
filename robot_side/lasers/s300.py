"""SICK S300 continuous data output (RS-422): telegram parsing and conversion to LaserScan. Pure: no I/O.

One telegram (all multi-byte fields little-endian except the size; sources in docs/sick-s300.md)::

    0   00 00 00 00        reply header (always zero in continuous output)
    4   00 00              data block number (zero)
    6   ss ss              telegram size in 16-bit words, BIG-endian (what it counts depends on the protocol)
    8   FF                 coordination flag
    9   aa                 device address (7; 8 for a slave scanner) - ROS ``scan_id``
    10  vv vv              protocol version: 02 01 = 1.02 (old), 03 01 = 1.03 (new)
    12  st st              status (00 00 normal, 01 00 lockout)
    14  nn nn nn nn        scan number (the scanner's 40 ms time stamp)
    18  tt tt              telegram number
    20  BB BB              block type: AAAA I/O, BBBB distances, CCCC reflectors
    22  11 11              measurement field 1111 .. 5555
    24  d0 d0 d1 d1 ...    values: bits 0-12 distance in cm, 13 reflector, 14 protective field, 15 warning field
    -2  cc cc              CRC-16 (poly 0x1021, init 0xFFFF) over bytes 4 .. -3, low byte first

Total length in bytes from the size word ``s``: old protocol ``4 + 2 s``; new protocol ``14 + 2 s`` when a
measurement field is configured, ``8 + 2 s`` when none is (told apart by the CRC, as cob_sick_s300 does).

    telegram_to_scan(data, params, received) -> LaserScan     # one whole telegram, e.g. for benchmarks
    stream = TelegramStream(); stream.feed(chunk) -> [Telegram, ...]   # resynchronising byte stream
"""

from __future__ import annotations

import binascii
import math
from dataclasses import dataclass

import numpy as np

from common.messages import Header, LaserScan
from robot_side.lasers.s300_params import S300Field, S300Params, load  # noqa: F401 - re-exported

SYNC = bytes(6)  # reply header + data block number
HEADER_BYTES = 24
CRC_BYTES = 2
MIN_TELEGRAM_BYTES = HEADER_BYTES + CRC_BYTES
MAX_TELEGRAM_BYTES = 4096  # a full S300 telegram is ~1.1 kB; a larger size word is a false header
COORDINATION_FLAG = 0xFF
OLD_PROTOCOL = 0x0102
BLOCK_IO, BLOCK_DISTANCE, BLOCK_REFLECTOR = 0xAAAA, 0xBBBB, 0xCCCC
DISTANCE_MASK = 0x1FFF
REFLECTOR_BIT, PROTECTIVE_BIT, WARNING_BIT = 0x2000, 0x4000, 0x8000
STANDBY_VALUE = 0x4004  # every value of a scan in standby (cob_sick_s300)


class TelegramError(ValueError):
    """Not a (usable) S300 telegram."""


class CRCError(TelegramError):
    """The telegram's CRC does not match its contents."""


def crc16(data: bytes | bytearray | memoryview) -> int:
    """CRC-16 with polynomial 0x1021, initial value 0xFFFF, no reflection, no final xor."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclass(frozen=True)
class Telegram:
    version: int
    address: int
    status: int
    scan_number: int
    telegram_number: int
    block: int
    field: int  # 1..5 (0 when the field word is not 1111..5555)
    values: np.ndarray  # uint16, raw 16-bit words of the data block

    @property
    def is_distance(self) -> bool:
        return self.block == BLOCK_DISTANCE

    @property
    def in_standby(self) -> bool:
        return self.values.size > 0 and bool(np.all(self.values == STANDBY_VALUE))


def candidate_lengths(head: bytes | bytearray) -> tuple[int, ...]:
    """Possible total lengths of the telegram whose first 12 bytes are ``head`` (shortest first)."""
    words2 = 2 * int.from_bytes(head[6:8], "big")
    if head[10] | head[11] << 8 == OLD_PROTOCOL:
        return (4 + words2,)
    return (8 + words2, 14 + words2)


def is_header(buf: bytes | bytearray, i: int = 0) -> bool:
    """A plausible telegram start at ``buf[i]`` (needs 12 bytes): sync, coordination flag, sane size."""
    if buf[i:i + 6] != SYNC or buf[i + 8] != COORDINATION_FLAG:
        return False
    lengths = candidate_lengths(buf[i:i + 12])
    return lengths[-1] >= MIN_TELEGRAM_BYTES and lengths[0] <= MAX_TELEGRAM_BYTES


def crc_ok(telegram: bytes | bytearray | memoryview) -> bool:
    body = memoryview(telegram)
    return crc16(body[4:-2]) == (body[-2] | body[-1] << 8)


def decode(data: bytes | bytearray) -> Telegram:
    """One complete telegram (CRC already checked) -> Telegram; the values are a copy."""
    n = (len(data) - MIN_TELEGRAM_BYTES) // 2
    if n < 0 or (len(data) - MIN_TELEGRAM_BYTES) % 2:
        raise TelegramError(f"telegram of {len(data)} bytes: no whole data block")
    le = int.from_bytes
    field_word = le(data[22:24], "little")
    field = field_word // 0x1111 if field_word % 0x1111 == 0 and 1 <= field_word // 0x1111 <= 5 else 0
    return Telegram(version=le(data[10:12], "little"), address=data[9], status=le(data[12:14], "little"),
                    scan_number=le(data[14:18], "little"), telegram_number=le(data[18:20], "little"),
                    block=le(data[20:22], "little"), field=field,
                    values=np.frombuffer(bytes(data[HEADER_BYTES:HEADER_BYTES + 2 * n]), dtype="<u2").copy())


def parse_telegram(data: bytes | bytearray) -> Telegram:
    """Exactly one telegram -> Telegram; TelegramError (CRCError for a checksum mismatch) otherwise."""
    if len(data) < MIN_TELEGRAM_BYTES or not is_header(data):
        raise TelegramError("no S300 telegram header (00 00 00 00 00 00 size FF address)")
    lengths = candidate_lengths(data)
    if len(data) not in lengths:
        raise TelegramError(f"{len(data)} bytes; the size word says {' or '.join(map(str, lengths))}")
    if not crc_ok(data):
        raise CRCError(f"CRC mismatch in a {len(data)}-byte telegram")
    return decode(data)


class TelegramStream:
    """Splits a byte stream into checked telegrams, resynchronising on garbage and broken telegrams.

    Counters: ``telegrams`` (passed the CRC), ``crc_errors`` (a header whose telegram failed the CRC,
    truncated ones included) and ``garbage_bytes`` (bytes outside every good telegram)."""

    def __init__(self) -> None:
        self.buf = bytearray()
        self.telegrams = self.crc_errors = self.garbage_bytes = 0

    def _skip(self, n: int) -> None:
        self.garbage_bytes += n
        del self.buf[:n]

    def feed(self, data: bytes) -> list[Telegram]:
        buf = self.buf
        out: list[Telegram] = []
        buf += data
        while True:
            i = buf.find(SYNC)
            if i < 0:
                self._skip(max(0, len(buf) - (len(SYNC) - 1)))  # keep a possible partial sync
                return out
            if i:
                self._skip(i)
            if len(buf) < 12:
                return out
            if not is_header(buf):
                self._skip(1)
                continue
            lengths = candidate_lengths(buf)
            if len(buf) < lengths[0]:
                return out
            good = next((n for n in lengths if n <= len(buf) and crc_ok(memoryview(buf)[:n])), None)
            if good is None:
                if len(buf) < lengths[-1]:
                    return out  # the longer layout may still complete
                self.crc_errors += 1
                self._skip(1)  # never trust the size of a broken telegram: look for the next header
                continue
            try:
                out.append(decode(buf[:good]))
                self.telegrams += 1
            except TelegramError:
                self.crc_errors += 1
                self._skip(1)
                continue
            del buf[:good]


def scan_from_telegram(t: Telegram, p: S300Params, received: float = 0.0) -> LaserScan:
    """A distance telegram -> LaserScan as the simulator publishes it (SI units, float32, +inf = no
    return at or beyond ``range_max``, -inf below ``range_min``), cut to ``angle_min``..``angle_max``.

    The stamp is ``received - scan_duration`` (the
    scan began that long before its telegram arrived), or ``received`` for an ``inverted`` scanner
    whose beams run backwards in time (``time_increment`` negative), as cob_sick_s300 does."""
    if not t.is_distance:
        raise TelegramError(f"block type {t.block:04X} is not distance data")
    f = p.fields.get(t.field)
    if f is None:
        raise TelegramError(f"measurement field {t.field} is not configured (fields: {sorted(p.fields)})")
    n = t.values.size
    if n < 2:
        raise TelegramError(f"{n} distance value(s)")
    d = (t.values & DISTANCE_MASK) * f.scale  # float64: the limits compare exactly
    r = d.astype(np.float32)
    r[d >= p.range_max] = np.inf
    r[d < p.range_min] = -np.inf
    if p.inverted:
        r = r[::-1]
    inc = (f.stop_angle - f.start_angle) / (n - 1)
    lo, hi = 0, n - 1
    if p.angle_min is not None:
        lo = max(lo, math.ceil((p.angle_min - f.start_angle) / inc - 1e-6))
    if p.angle_max is not None:
        hi = min(hi, math.floor((p.angle_max - f.start_angle) / inc + 1e-6))
    if hi < lo:
        raise TelegramError(f"angle_min..angle_max leaves no beam of field {t.field}")
    dt = p.scan_duration / n
    return LaserScan(header=Header(received if p.inverted else received - p.scan_duration, p.frame_id),
                     angle_min=f.start_angle + lo * inc, angle_max=f.start_angle + hi * inc,
                     angle_increment=inc, time_increment=-dt if p.inverted else dt,
                     scan_time=p.scan_cycle_time, range_min=p.range_min, range_max=p.range_max,
                     ranges=np.ascontiguousarray(r[lo:hi + 1]))


def telegram_to_scan(data: bytes, p: S300Params, received: float = 0.0) -> LaserScan:
    """One raw telegram (bytes, from the first 00 to the CRC) + S300Params -> LaserScan."""
    return scan_from_telegram(parse_telegram(data), p, received)
