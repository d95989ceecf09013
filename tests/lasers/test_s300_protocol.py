"""S300 telegram parsing and conversion (robot_side.lasers.s300) against the fake scanner's independent
encoder (robot_side.lasers.fake_s300): every header layout, CRC, flag bits, range limits, the cut,
inverted mounting and the resynchronising stream."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from robot_side.lasers import s300
from robot_side.lasers.fake_s300 import LAYOUTS, FakeS300, crc_ccitt, encode_telegram
from robot_side.lasers.s300 import S300Params, TelegramStream, load, parse_telegram, telegram_to_scan

ROOM = (-2.0, 4.0, -3.0, math.inf)  # open on the left: those beams see nothing


def fake(**kw) -> FakeS300:
    return FakeS300(-1, **{"room": ROOM, **kw})  # no pty: only its encoder and room are used


def test_crc_is_ccitt_with_preset_ffff_in_both_implementations():
    assert s300.crc16(b"123456789") == 0x29B1 == crc_ccitt(b"123456789")  # the CRC-16/CCITT-FALSE check value
    data = np.random.default_rng(3).integers(0, 256, 1100, dtype=np.uint8).tobytes()
    assert s300.crc16(data) == crc_ccitt(data)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_header_layout_decodes_to_the_words_sent(layout):
    f = fake(layout=layout)
    data = encode_telegram(f.words(), scan_number=70000, telegram_number=12, layout=layout, address=7, field=1)
    assert len(data) == 24 + 2 * 541 + 2
    t = parse_telegram(data)
    assert (t.scan_number, t.telegram_number, t.address, t.field, t.block) == (70000, 12, 7, 1, 0xBBBB)
    assert t.version == (0x0102 if layout == "old" else 0x0103)
    np.testing.assert_array_equal(t.values, f.words())


def test_scan_matches_the_room_with_flag_bits_masked_and_no_return_as_inf():
    f = fake()
    words = f.words()
    assert (words & 0xE000).any()  # the fake sets reflector / protective / warning bits
    scan = telegram_to_scan(f.telegram(0), S300Params(), received=100.0)
    truth = f.true_ranges()
    assert scan.ranges.dtype == np.float32 and len(scan.ranges) == 541
    hit = np.isfinite(truth)
    assert 100 < hit.sum() < 541
    np.testing.assert_allclose(scan.ranges[hit], truth[hit], atol=0.0051)  # cm resolution
    assert np.all(np.isposinf(scan.ranges[~hit]))
    assert scan.angle_min == pytest.approx(-math.radians(135)) and scan.angle_max == pytest.approx(math.radians(135))
    assert scan.angle_increment == pytest.approx(math.radians(0.5))
    np.testing.assert_allclose(scan.angles(), f.angles, atol=1e-9)
    assert scan.header.stamp == pytest.approx(100.0 - 0.025) and scan.header.frame_id == "laser"
    assert scan.time_increment == pytest.approx(0.025 / 541) and scan.scan_time == pytest.approx(0.04)
    assert (scan.range_min, scan.range_max) == (0.05, 30.0)


def test_range_limits_make_far_values_plus_inf_and_near_ones_minus_inf():
    f = fake(room=(-0.03, 4.0, -3.0, 3.0))  # a wall 3 cm behind the scanner
    scan = telegram_to_scan(f.telegram(0), S300Params(range_max=3.5), 0.0)
    truth = f.true_ranges()
    assert np.array_equal(np.isposinf(scan.ranges), np.round(truth * 100) * 0.01 >= 3.5 - 1e-6)
    assert np.array_equal(np.isneginf(scan.ranges), np.round(truth * 100) * 0.01 < 0.05 - 1e-6)
    assert np.isneginf(scan.ranges).any() and np.isposinf(scan.ranges).any()


def test_fov_cut_keeps_the_beams_between_angle_min_and_angle_max():
    f = fake()
    full = telegram_to_scan(f.telegram(0), S300Params(), 0.0)
    cut = telegram_to_scan(f.telegram(0), S300Params(angle_min=-math.pi / 2, angle_max=math.pi / 4), 0.0)
    assert len(cut.ranges) == 180 + 90 + 1
    assert cut.angle_min == pytest.approx(-math.pi / 2) and cut.angle_max == pytest.approx(math.pi / 4)
    np.testing.assert_array_equal(cut.ranges, full.ranges[90:90 + 271])


def test_field_angles_and_scale_come_from_the_fields_parameter():
    f = fake()
    p = load({"fields": {1: {"scale": 0.02, "start_angle": -1.0, "stop_angle": 1.0}}}, "t.yaml")
    scan = telegram_to_scan(f.telegram(0), p, 0.0)
    full = telegram_to_scan(f.telegram(0), S300Params(range_max=81.91), 0.0)
    assert (scan.angle_min, scan.angle_max) == (pytest.approx(-1.0), pytest.approx(1.0))
    ok = np.isfinite(scan.ranges)
    np.testing.assert_allclose(scan.ranges[ok], 2 * full.ranges[ok], rtol=1e-6)
    with pytest.raises(s300.TelegramError, match="field 2"):
        telegram_to_scan(encode_telegram(f.words(), 0, 0, field=2), p, 0.0)


def test_inverted_scanner_reverses_the_beams_and_stamps_the_reception():
    f = fake()
    up = telegram_to_scan(f.telegram(0), S300Params(), 5.0)
    down = telegram_to_scan(f.telegram(0), S300Params(inverted=True), 5.0)
    np.testing.assert_array_equal(down.ranges, up.ranges[::-1])
    assert down.header.stamp == 5.0 and down.time_increment == pytest.approx(-up.time_increment)


def test_broken_telegrams_raise():
    data = fake().telegram(0)
    with pytest.raises(s300.CRCError):
        parse_telegram(data[:-1] + bytes([data[-1] ^ 1]))
    with pytest.raises(s300.CRCError):
        parse_telegram(data[:100] + bytes([data[100] ^ 0x10]) + data[101:])
    with pytest.raises(s300.TelegramError, match="size word"):
        parse_telegram(data[:-4])
    with pytest.raises(s300.TelegramError, match="header"):
        parse_telegram(b"\x01" + data[1:])


@pytest.mark.parametrize("chunk", [1, 37, 5000])
def test_stream_resynchronises_on_mid_telegram_start_garbage_truncation_and_crc_errors(chunk):
    f = fake()
    good = [f.telegram(i) for i in range(5)]
    bad_crc = good[3][:-2] + bytes([good[3][-2] ^ 0xFF, good[3][-1]])
    garbage = bytes(range(1, 200))
    data = (good[0][400:] + good[1] + garbage + good[2] + good[0][:700] + bad_crc + good[4])
    stream, out = TelegramStream(), []
    for i in range(0, len(data), chunk):
        out += stream.feed(data[i:i + chunk])
    assert [t.scan_number for t in out] == [1, 2, 4]
    assert (stream.telegrams, stream.crc_errors) == (3, 2)  # the truncated one and the bad CRC
    assert stream.garbage_bytes >= len(good[0]) - 400 + len(garbage) + 700 + len(bad_crc)


def test_false_header_inside_zero_distances_does_not_lose_the_next_telegram():
    f = fake()
    words = f.words()
    words[100:104] = 0
    words[104] = 0xFF00  # 8 zero bytes then FF: looks like a header to a byte scanner
    t0, t1 = encode_telegram(words, 0, 0), f.telegram(1)
    stream = TelegramStream()
    out = stream.feed(t0[:30] + t0[31:] + t1)  # t0 loses a byte; its data then holds the false header
    assert [t.scan_number for t in out] == [1]


def test_config_errors_name_every_bad_key():
    with pytest.raises(ConfigError) as e:
        load({"baud": 123, "prot": "/dev/x", "fields": {"1": {"scale": -1.0, "start_angle": 0.0,
                                                             "stop_angle": 1.0}, "9": {}}}, "s.yaml")
    keys = {k for _, k, _ in e.value.problems}
    assert keys == {"baud", "prot", "fields.1.scale", "fields.9"}
    with pytest.raises(ConfigError, match="angle_max"):
        load({"angle_min": 1.0, "angle_max": 0.5}, "s.yaml")
    assert load({"fields": {"2": {"scale": 0.01, "start_angle": -1, "stop_angle": 1}}}, "s").fields.keys() == {2}
