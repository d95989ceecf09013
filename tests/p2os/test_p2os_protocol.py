"""P2OS packets: bytes checked against hand-computed values (../shared/notes/p2os-protocol.md), command
and SIP round trips, and the streaming parser's resync on line noise."""

from __future__ import annotations

import math

import pytest

from robot_side.p2os import protocol as P
from robot_side.p2os.sip import MODELS, Sip, decode_sip, encode_sip, is_sip, parse_sync2, to_si


def h(s: str) -> bytes:
    return bytes.fromhex(s)


@pytest.mark.parametrize(("packet", "expected"), [
    (P.sync(0), "fa fb 03 00 00 00"),  # notes: SYNC0 / PULSE
    (P.pulse(), "fa fb 03 00 00 00"),
    (P.open_(), "fa fb 03 01 00 01"),  # notes: OPEN
    (P.close(), "fa fb 03 02 00 02"),  # odd body: 0x02 XORed into the low byte
    (P.enable(True), "fa fb 06 04 3b 01 00 05 3b"),  # notes / manual: ENABLE 1
    (P.vel(-200), "fa fb 06 0b 1b c8 00 d3 1b"),  # notes: VEL -200 (ARGNINT, magnitude LE)
    (P.rvel(30), "fa fb 06 15 3b 1e 00 33 3b"),  # 0x153b + 0x1e00 = 0x333b
    (P.vel2(100, 200), "fa fb 06 20 3b 05 0a 25 45"),  # right 10, left 5 units of 20 mm/s
    (P.sonar(False), "fa fb 06 1c 3b 00 00 1c 3b"),
])
def test_command_bytes_match_hand_computed_packets(packet, expected):
    assert packet == h(expected)


def test_checksum_wraps_at_16_bits_and_xors_an_odd_last_byte():
    assert P.checksum(h("ff ff 00 02")) == 0x0001  # 0xffff + 0x0002 carries out of 16 bits
    assert P.checksum(h("01 02 03")) == 0x0102 ^ 0x03
    assert P.checksum(h("02 41 00")) == 0x0241


@pytest.mark.parametrize("arg", [None, 0, 1, -1, 1200, -1200, 0xFFFF, -0xFFFF, b"hello"])
def test_command_round_trip_through_the_parser(arg):
    parser = P.PacketParser()
    (body,) = parser.feed(P.command(P.Command.VEL, arg))
    assert P.decode_command(body) == (P.Command.VEL, arg)


def test_command_refuses_arguments_that_do_not_fit():
    with pytest.raises(P.ProtocolError):
        P.command(P.Command.VEL, 0x10000)


def test_parser_resyncs_after_garbage_a_false_header_and_a_bad_checksum():
    good = [P.vel(100), P.rvel(-20), P.pulse()]
    bad = bytearray(P.enable(True))
    bad[-1] ^= 0xFF  # corrupted checksum
    stream = (b"\x00\x13\xfa\x99" + good[0] + b"\xfa\xfb\xff" + bytes(bad) + good[1] + b"\xfa" + good[2])
    parser = P.PacketParser()
    bodies = parser.feed(stream)
    assert [P.decode_command(b) for b in bodies] == [(11, 100), (21, -20), (0, None)]
    assert parser.stats.bad_checksum == 1
    assert parser.stats.bad_length == 1  # count 0xff is impossible
    assert parser.stats.garbage_bytes > 0
    assert parser.stats.packets == 3


def test_parser_finds_a_packet_hidden_inside_a_rejected_one():
    # a truncated packet (its length claims the following packet's bytes) must not swallow a good packet
    truncated = P.vel(500)[:5]
    parser = P.PacketParser()
    assert parser.feed(truncated + P.rvel(7) + P.pulse()) == [h("15 3b 07 00"), h("00")]
    assert parser.stats.bad_checksum + parser.stats.bad_length >= 1


def test_parser_reassembles_packets_split_across_reads_byte_by_byte():
    stream = P.vel(-321) + b"\xfa" + P.open_()
    parser = P.PacketParser()
    out = [b for i in range(len(stream)) for b in parser.feed(stream[i:i + 1])]
    assert [P.decode_command(b) for b in out] == [(11, -321), (1, None)]
    assert parser.stats.garbage_bytes == 1


def test_parser_never_raises_on_random_bytes():
    import random

    rng = random.Random(7)
    parser = P.PacketParser()
    for _ in range(200):
        parser.feed(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 64))))
    # a false header left by the noise is rejected at the latest once a maximum-length packet has arrived
    assert h("0b 3b 2a 00") in parser.feed(P.vel(42) + bytes(P.MAX_COUNT + 1))
    assert len(parser.buf) <= parser.max_buffer


# A standard SIP written out byte by byte (see robot_side/p2os/sip.py for the layout).
SIP_BYTES = h("32" "3412" "ff7f" "00f8" "38ff" "c800" "7e" "01" "00" "0000" "0100" "2d" "01" "031027"
              "0000000000")


def test_sip_decodes_every_field_of_a_hand_written_packet():
    s = decode_sip(SIP_BYTES)
    assert is_sip(SIP_BYTES)
    assert (s.status, s.x_raw, s.y_raw, s.th_raw) == (0x32, 0x1234, 0x7FFF, -2048)
    assert (s.lvel_raw, s.rvel_raw, s.battery_dv, s.compass) == (-200, 200, 126, 45)
    assert (s.motors_enabled, s.left_stalled, s.right_stalled, s.moving) == (True, True, False, False)
    assert s.sonars == ((3, 10000),)


def test_sip_si_conversion_uses_the_p3at_factors():
    r = to_si(decode_sip(SIP_BYTES), MODELS["p3at"])
    assert r.v == pytest.approx(0.0)
    assert r.w == pytest.approx(200 * 0.0034)  # (r - l)/2 mm/s x DiffConvFactor
    assert abs(r.theta) == pytest.approx(math.pi, abs=1e-3)  # -2048 x AngleConvFactor
    assert r.battery_voltage == pytest.approx(12.6)
    assert r.sonar_ranges == ((3, pytest.approx(10.0)),)
    assert (r.motors_enabled, r.left_stalled) == (True, True)


def test_sip_encode_decode_round_trip_survives_framing():
    s = Sip(status=0x33, x_raw=32767, y_raw=5, th_raw=-1000, lvel_raw=-1200, rvel_raw=1199, battery_dv=131,
            stall_bump_left=0x03, stall_bump_right=0x81, control=77, flags=0x1F, compass=90,
            sonars=((0, 500), (15, 5000)))
    (body,) = P.PacketParser().feed(P.frame(encode_sip(s)))
    assert decode_sip(body) == s
    assert s.bumpers == (0x40 | 0x01 << 8)


def test_truncated_sip_is_a_protocol_error():
    with pytest.raises(P.ProtocolError):
        decode_sip(SIP_BYTES[:15])
    with pytest.raises(P.ProtocolError):
        decode_sip(SIP_BYTES[:20])  # announces one sonar reading that is missing


def test_sync2_reply_names_the_robot_and_its_subclass():
    assert parse_sync2(b"\x02Pioneer3\0Pioneer\0p3at-sh\0") == ("Pioneer3", "Pioneer", "p3at-sh")
    assert parse_sync2(b"\x02") == ("", "", "")
