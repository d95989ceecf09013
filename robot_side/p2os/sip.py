"""The standard server information packet (SIP) of a Pioneer: decode, encode, SI conversion and the
odometry integration of its wrapping position counters (pure).

SIP body layout (offsets in the body, i.e. after ``FA FB count``; integers little-endian)::

    0     status/type   0x3S: S=2 motors stopped, 3 moving (0x30..0x3F accepted)
    1-2   xpos          uint16, 15 low bits used, wraps; Δ × DistConvFactor = mm
    3-4   ypos          as xpos
    5-6   thpos         int16 × AngleConvFactor = rad (absolute, -2048..2047 for 2π/4096)
    7-8   lvel          int16 × VelConvFactor = mm/s
    9-10  rvel          int16 × VelConvFactor = mm/s
    11    battery       volts × 10
    12    stall/bump L  bit 0 left wheels stalled, bits 1-7 rear bumpers
    13    stall/bump R  bit 0 right wheels stalled, bits 1-7 front bumpers
    14-15 control       heading set point (angle units)
    16-17 flags         bit 0 motors enabled, bits 1-4 sonar arrays on
    18    compass       2° units
    19    sonar count   then count × (sonar number byte, uint16 range × RangeConvFactor = mm)
    then  gripper state, analog port, analog, digital in, digital out (1 byte each; optional here)

Sources: Pioneer 3 Operations Manual, "Standard SIP" table (15-bit position counters, battery ×10);
the p2os driver p2os_driver/src/sip.cpp (field order, 4096-unit wrap via ``% 4096`` and shortest
difference; v = (l + r)/2, ω = (r − l)/2 × DiffConvFactor — the same formula as ARIA's
ArRobot::processMotorPacket) and p2os_driver/src/robot_params.cpp (per-model factors below).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from common.geometry import Pose2D, normalize_angle, pivoted
from robot_side.p2os.protocol import ProtocolError


@dataclass(frozen=True)
class RobotModel:
    """Per-model conversion factors (ARIA / p2os robot parameter names)."""

    subclass: str
    dist_conv_factor: float  # DistConvFactor: position unit -> mm
    angle_conv_factor: float  # AngleConvFactor: angle unit -> rad
    vel_conv_factor: float  # VelConvFactor: wheel velocity unit -> mm/s
    diff_conv_factor: float  # DiffConvFactor: (r - l)/2 mm/s -> rad/s
    range_conv_factor: float  # RangeConvFactor: sonar unit -> mm
    vel2_divisor: float  # Vel2Divisor: VEL2 unit -> mm/s
    max_vel_mm_s: float  # MaxVelocity
    max_rvel_deg_s: float  # MaxRVelocity
    sonar_count: int


# p2os robot_params.cpp entries "p3at" (old P2OS/uC controller) and "p3at-sh" (ARCOS on the SH
# controller: DistConvFactor 1.0); everything else is identical.
MODELS: dict[str, RobotModel] = {
    "p3at": RobotModel("p3at", 0.465, 0.001534, 1.0, 0.0034, 1.0, 20.0, 1200.0, 300.0, 16),
    "p3at-sh": RobotModel("p3at-sh", 1.0, 0.001534, 1.0, 0.0034, 1.0, 20.0, 1200.0, 300.0, 16),
}


def model_for(subclass: str) -> RobotModel | None:
    return MODELS.get(subclass.strip().lower())


@dataclass(frozen=True)
class Sip:
    """A standard SIP in the robot's own units (raw integers)."""

    status: int = 0x32
    x_raw: int = 0
    y_raw: int = 0
    th_raw: int = 0
    lvel_raw: int = 0
    rvel_raw: int = 0
    battery_dv: int = 0  # volts x 10
    stall_bump_left: int = 0
    stall_bump_right: int = 0
    control: int = 0
    flags: int = 0
    compass: int = 0
    sonars: tuple[tuple[int, int], ...] = ()  # (sonar number, raw range)

    @property
    def motors_enabled(self) -> bool:
        return bool(self.flags & 0x01)

    @property
    def moving(self) -> bool:
        return self.status & 0x0F == 0x03

    @property
    def left_stalled(self) -> bool:
        return bool(self.stall_bump_left & 0x01)

    @property
    def right_stalled(self) -> bool:
        return bool(self.stall_bump_right & 0x01)

    @property
    def bumpers(self) -> int:
        """Front bumpers in bits 0-6, rear bumpers in bits 8-14."""
        return (self.stall_bump_right >> 1) | (self.stall_bump_left >> 1) << 8


def is_sip(body: bytes) -> bool:
    return len(body) >= 1 and body[0] & 0xF0 == 0x30


def _u16(b: bytes, i: int) -> int:
    return b[i] | b[i + 1] << 8


def _s16(b: bytes, i: int) -> int:
    v = _u16(b, i)
    return v - 0x10000 if v & 0x8000 else v


def decode_sip(body: bytes) -> Sip:
    if not is_sip(body):
        raise ProtocolError(f"not a standard SIP (type 0x{body[0] if body else 0:02x})")
    if len(body) < 20:
        raise ProtocolError(f"SIP too short: {len(body)} bytes")
    n = body[19]
    if len(body) < 20 + 3 * n:
        raise ProtocolError(f"SIP announces {n} sonar readings but has {len(body)} bytes")
    sonars = tuple((body[20 + 3 * k], _u16(body, 21 + 3 * k)) for k in range(n))
    return Sip(status=body[0], x_raw=_u16(body, 1) & 0x7FFF, y_raw=_u16(body, 3) & 0x7FFF,
               th_raw=_s16(body, 5), lvel_raw=_s16(body, 7), rvel_raw=_s16(body, 9), battery_dv=body[11],
               stall_bump_left=body[12], stall_bump_right=body[13], control=_s16(body, 14),
               flags=_u16(body, 16), compass=body[18], sonars=sonars)


def encode_sip(s: Sip) -> bytes:
    """The body of a standard SIP (for the simulated device); decode_sip(encode_sip(s)) == s."""
    def i16(v: int) -> bytes:
        return (int(v) & 0xFFFF).to_bytes(2, "little")
    body = bytearray([s.status & 0xFF])
    body += i16(s.x_raw & 0x7FFF) + i16(s.y_raw & 0x7FFF) + i16(s.th_raw) + i16(s.lvel_raw) + i16(s.rvel_raw)
    body += bytes([s.battery_dv & 0xFF, s.stall_bump_left & 0xFF, s.stall_bump_right & 0xFF])
    body += i16(s.control) + i16(s.flags) + bytes([s.compass & 0xFF, len(s.sonars)])
    for idx, rng in s.sonars:
        body += bytes([idx & 0xFF]) + i16(rng)
    body += bytes(5)  # gripper state, analog port, analog, digital in, digital out
    return bytes(body)


def parse_sync2(body: bytes) -> tuple[str, str, str]:
    """(name, class, subclass) from the robot's SYNC2 reply: NUL-terminated strings after byte 0."""
    parts = bytes(body[1:]).split(b"\0")
    parts += [b""] * 3
    return tuple(p.decode("ascii", "replace").strip() for p in parts[:3])  # type: ignore[return-value]


# ---------------------------------------------------------------------- SI conversion
@dataclass(frozen=True)
class BaseReading:
    """One SIP in SI units."""

    v: float  # m/s, forward
    w: float  # rad/s, counter-clockwise
    theta: float  # rad, the robot's absolute heading counter
    battery_voltage: float  # V
    motors_enabled: bool
    left_stalled: bool
    right_stalled: bool
    bumpers: int
    sonar_ranges: tuple[tuple[int, float], ...]  # (sonar number, m)


def to_si(s: Sip, m: RobotModel) -> BaseReading:
    left_mm_s, right_mm_s = s.lvel_raw * m.vel_conv_factor, s.rvel_raw * m.vel_conv_factor
    return BaseReading(
        v=(left_mm_s + right_mm_s) / 2.0 / 1000.0,
        w=(right_mm_s - left_mm_s) / 2.0 * m.diff_conv_factor,
        theta=normalize_angle(s.th_raw * m.angle_conv_factor),
        battery_voltage=s.battery_dv / 10.0,
        motors_enabled=s.motors_enabled, left_stalled=s.left_stalled, right_stalled=s.right_stalled,
        bumpers=s.bumpers,
        sonar_ranges=tuple((i, r * m.range_conv_factor / 1000.0) for i, r in s.sonars))


def position_delta(old_raw: int, new_raw: int, bits: int) -> int:
    """Shortest signed change of a position counter that wraps at 2**bits (raw units)."""
    mod = 1 << bits
    d = (new_raw - old_raw) % mod
    return d - mod if d >= mod // 2 else d


class OdometryIntegrator:
    """Continuous odom pose from the SIP's wrapping x/y counters and absolute heading.

    The first SIP defines the odom origin (pose (0, 0, 0)); x/y changes are accumulated in the robot's
    internal frame modulo 2**``wrap_bits`` (12 as p2os — valid for any counter wrapping at a multiple
    of 4096 while one SIP period moves less than 2048 units — or 15 as the ARCOS manual's counters).
    With ``rotation_center_x`` each SIP's increment is taken as a turn about that point of base_link
    (``common.geometry.pivoted``) instead of about the axles' middle, where the firmware integrates it.
    """

    def __init__(self, model: RobotModel, wrap_bits: int = 12, rotation_center_x: float = 0.0) -> None:
        if wrap_bits not in (12, 15):
            raise ValueError("wrap_bits must be 12 or 15")
        self.model, self.wrap_bits, self.rotation_center_x = model, wrap_bits, rotation_center_x
        self._firmware = Pose2D()  # the pose as the firmware integrates it (turns about the axles' middle)
        self._last: tuple[int, int] | None = None
        self._origin: Pose2D | None = None
        self._x_m = self._y_m = 0.0
        self.pose = Pose2D()

    def update(self, s: Sip) -> Pose2D:
        mask = (1 << self.wrap_bits) - 1
        x, y = s.x_raw & mask, s.y_raw & mask
        theta = normalize_angle(s.th_raw * self.model.angle_conv_factor)
        if self._last is not None:
            k = self.model.dist_conv_factor / 1000.0
            self._x_m += position_delta(self._last[0], x, self.wrap_bits) * k
            self._y_m += position_delta(self._last[1], y, self.wrap_bits) * k
        self._last = (x, y)
        internal = Pose2D(self._x_m, self._y_m, theta)
        if self._origin is None:
            self._origin = internal
        firmware = self._origin.between(internal)
        c = self.rotation_center_x
        self.pose = self.pose.compose(pivoted(self._firmware.between(firmware), c)) if c else firmware
        self._firmware = firmware
        return self.pose


def theta_to_raw(theta: float, m: RobotModel) -> int:
    """Heading in rad -> the SIP's angle units in [-2048, 2047] (for the simulated device)."""
    half = round(math.pi / m.angle_conv_factor)
    r = round(normalize_angle(theta) / m.angle_conv_factor)
    return max(-half, min(half - 1, r))
