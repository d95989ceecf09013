"""Pioneer P2OS / ARCOS serial packets: framing, checksum, command encoders and a resyncing parser (pure).

Packet layout (both directions)::

    FA FB <count> <body: count - 2 bytes> <checksum hi> <checksum lo>

``count`` is the body length plus the two checksum bytes (a packet holds at most ~200 bytes). The
checksum adds the body as big-endian 16-bit words (kept to 16 bits at each step) and XORs an odd last
byte into the sum. A command body is ``<command number> [<argument type> <argument>]``; an integer
argument is ARGINT (0x3B, value >= 0) or ARGNINT (0x1B, negative) followed by the magnitude as uint16
little-endian.

Sources: Pioneer 3 Operations Manual (ARCOS chapter: packet protocol, command list SYNC0 0, SYNC1 1,
SYNC2 2, PULSE 0, OPEN 1, CLOSE 2, ENABLE 4, SETA 5, SETV 6, SETO 7, SETRV 10, VEL 11, RVEL 21,
SETRA 23, SONAR 28, STOP 29, VEL2 32); the p2os driver (p2os_driver/src/packet.cc, p2os.cpp) for
the checksum and handshake; the known-good byte strings in ../shared/notes/p2os-protocol.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

HEADER = b"\xfa\xfb"
MAX_COUNT = 202  # body (<= 200 bytes) + checksum; anything longer is a false header
ARGINT, ARGNINT, ARGSTR = 0x3B, 0x1B, 0x2B


class Command(IntEnum):
    SYNC0 = 0
    PULSE = 0  # same number as SYNC0; PULSE once the connection is open
    SYNC1 = 1
    OPEN = 1  # same number as SYNC1; OPEN once synchronised
    SYNC2 = 2
    CLOSE = 2  # same number as SYNC2; CLOSE once synchronised
    ENABLE = 4
    SETA = 5
    SETV = 6
    SETO = 7
    SETRV = 10
    VEL = 11
    RVEL = 21
    SETRA = 23
    SONAR = 28
    STOP = 29
    VEL2 = 32


class ProtocolError(ValueError):
    """A packet that cannot be built or decoded."""


def checksum(body: bytes) -> int:
    """P2OS checksum of a packet body: 16-bit big-endian word sum, odd last byte XORed in."""
    c = 0
    n = len(body)
    for i in range(0, n - 1, 2):
        c = (c + ((body[i] << 8) | body[i + 1])) & 0xFFFF
    if n % 2:
        c ^= body[-1]
    return c


def frame(body: bytes) -> bytes:
    """A complete packet around ``body``."""
    if not 1 <= len(body) <= MAX_COUNT - 2:
        raise ProtocolError(f"packet body must be 1..{MAX_COUNT - 2} bytes, got {len(body)}")
    c = checksum(body)
    return HEADER + bytes([len(body) + 2]) + body + bytes([c >> 8, c & 0xFF])


def command(cmd: int, arg: int | bytes | None = None) -> bytes:
    """A command packet: no argument, a signed integer (ARGINT / ARGNINT) or a string (ARGSTR)."""
    if not 0 <= int(cmd) <= 255:
        raise ProtocolError(f"command number {cmd} out of 0..255")
    body = bytes([int(cmd)])
    if isinstance(arg, (bytes, bytearray)):
        if len(arg) > 199:
            raise ProtocolError("string argument longer than 199 bytes")
        body += bytes([ARGSTR, len(arg)]) + bytes(arg)
    elif arg is not None:
        v = int(arg)
        if abs(v) > 0xFFFF:
            raise ProtocolError(f"integer argument {v} does not fit in 16 bits")
        body += bytes([ARGINT if v >= 0 else ARGNINT]) + abs(v).to_bytes(2, "little")
    return frame(body)


def decode_command(body: bytes) -> tuple[int, int | bytes | None]:
    """(command number, argument) of a command packet body (what the robot receives)."""
    if not body:
        raise ProtocolError("empty command packet")
    cmd = body[0]
    if len(body) == 1:
        return cmd, None
    kind = body[1]
    if kind in (ARGINT, ARGNINT) and len(body) >= 4:
        mag = int.from_bytes(body[2:4], "little")
        return cmd, mag if kind == ARGINT else -mag
    if kind == ARGSTR and len(body) >= 3:
        return cmd, bytes(body[3:3 + body[2]])
    raise ProtocolError(f"command {cmd}: bad argument bytes {body[1:].hex()}")


# ---------------------------------------------------------------------- command encoders
def sync(n: int) -> bytes:
    if n not in (0, 1, 2):
        raise ProtocolError(f"SYNC{n} does not exist")
    return command(n)


def open_() -> bytes:
    return command(Command.OPEN)


def close() -> bytes:
    return command(Command.CLOSE)


def pulse() -> bytes:
    return command(Command.PULSE)


def enable(on: bool) -> bytes:
    return command(Command.ENABLE, 1 if on else 0)


def sonar(on: bool) -> bytes:
    return command(Command.SONAR, 1 if on else 0)


def stop() -> bytes:
    return command(Command.STOP)


def vel(vel_mm_s: int) -> bytes:
    """Translational velocity set point, mm/s (positive forward)."""
    return command(Command.VEL, int(vel_mm_s))


def rvel(rvel_deg_s: int) -> bytes:
    """Rotational velocity set point, deg/s (positive counter-clockwise)."""
    return command(Command.RVEL, int(rvel_deg_s))


def vel2(left_mm_s: float, right_mm_s: float, divisor_mm_s: float = 20.0) -> bytes:
    """Independent wheel velocities: one signed byte per wheel (right first) in ``divisor_mm_s`` units."""
    def unit(v: float) -> int:
        return max(-126, min(126, round(v / divisor_mm_s))) & 0xFF
    return command(Command.VEL2, unit(right_mm_s) << 8 | unit(left_mm_s))


def setv(max_vel_mm_s: int) -> bytes:
    return command(Command.SETV, int(max_vel_mm_s))


def setrv(max_rvel_deg_s: int) -> bytes:
    return command(Command.SETRV, int(max_rvel_deg_s))


# ---------------------------------------------------------------------- streaming parser
@dataclass
class ParserStats:
    packets: int = 0
    bad_checksum: int = 0
    bad_length: int = 0
    garbage_bytes: int = 0  # bytes skipped while looking for a header


class PacketParser:
    """Split a byte stream into packet bodies. Never raises on bad input: garbage before a header,
    impossible lengths and checksum failures are counted in ``stats`` and the parser resyncs on the
    next ``FA FB`` (searching inside the rejected bytes too, so a good packet is not lost)."""

    def __init__(self, max_buffer: int = 4096) -> None:
        self.buf = bytearray()
        self.stats = ParserStats()
        self.max_buffer = max_buffer

    def feed(self, data: bytes) -> list[bytes]:
        self.buf += data
        out: list[bytes] = []
        buf = self.buf
        while True:
            i = buf.find(HEADER)
            if i < 0:
                keep = 1 if buf.endswith(HEADER[:1]) else 0  # a header may be split across reads
                self.stats.garbage_bytes += len(buf) - keep
                del buf[:len(buf) - keep]
                break
            if i:
                self.stats.garbage_bytes += i
                del buf[:i]
            if len(buf) < 3:
                break
            count = buf[2]
            if count < 3 or count > MAX_COUNT:
                self.stats.bad_length += 1
                del buf[:1]  # drop the false FA, rescan
                continue
            if len(buf) < 3 + count:
                break
            body = bytes(buf[3:1 + count])
            got = (buf[1 + count] << 8) | buf[2 + count]
            if got != checksum(body):
                self.stats.bad_checksum += 1
                del buf[:1]
                continue
            del buf[:3 + count]
            self.stats.packets += 1
            out.append(body)
        if len(buf) > self.max_buffer:  # cannot happen with MAX_COUNT, kept as a hard bound
            self.stats.garbage_bytes += len(buf)
            buf.clear()
        return out
