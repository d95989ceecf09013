"""SCIP 2.0 codec (robot_side.lasers.scip) against the specification's own examples and against replies
built by the simulated device's independent encoder (robot_side.lasers.fake_hokuyo)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.messages import LaserScan
from robot_side.lasers import scip as S
from robot_side.lasers.fake_hokuyo import FakeHokuyo

# the PP example of the URG network wiki (scip_status_en), sums as printed there
PP_REPLY = (b"PP\n00P\nMODL:URG-04LX(Hokuyo Automatic Co.,Ltd.);N\nDMIN:20;4\nDMAX:5600;_\nARES:1024;\\\n"
            b"AMIN:44;7\nAMAX:725;o\nAFRT:384;6\nSCAN:600;e\n")


def test_character_decoding_matches_the_specification_examples():
    assert S.decode(b"CB") == 1234  # 2-character example
    assert S.decode(b"1Dh") == 5432  # 3-character example
    assert S.decode(b"m2@0") == 16_000_000  # 4-character (timestamp) example
    assert S.decode_array(b"CB1D", 2).tolist() == [1234, S.decode(b"1D")]
    assert S.decode_array(b"1Dh1Dh", 3).tolist() == [5432, 5432]
    with pytest.raises(S.ScipError):
        S.decode_array(b"1Dh1", 3)


def test_checksum_is_the_low_six_bits_of_the_byte_sum_plus_0x30():
    assert bytes([S.checksum(b"00")]) == b"P"  # "00P" status line
    assert bytes([S.checksum(b"99")]) == b"b"  # "99b" scan data status
    assert bytes([S.checksum(b"DMIN:20")]) == b"4"  # parameter lines: the ';' is not summed


def test_pp_reply_gives_the_sensor_geometry_and_the_crop_steps():
    info = S.parse_info(S.parse_reply(PP_REPLY))
    sp = S.SensorParams.from_pp(info)
    assert (sp.dmin_mm, sp.dmax_mm, sp.ares, sp.amin, sp.amax, sp.afrt, sp.scan_rpm) == (20, 5600, 1024, 44, 725,
                                                                                        384, 600)
    assert sp.model.startswith("URG-04LX")
    assert sp.angle(384) == 0.0
    assert sp.angle(384 + 256) == pytest.approx(math.pi / 2)  # counter-clockwise, 2 pi / ARES per step
    assert sp.scan_period == pytest.approx(0.1)
    assert sp.steps_for(-math.pi, math.pi) == (44, 725)  # clipped to the measurable steps
    lo, hi = sp.steps_for(-0.5, 0.25)
    assert sp.angle(lo) >= -0.5 > sp.angle(lo - 1) and sp.angle(hi) <= 0.25 < sp.angle(hi + 1)
    with pytest.raises(ValueError, match="no steps"):
        sp.steps_for(3.0, 3.1)


def test_a_corrupt_parameter_line_and_an_error_status_are_reported():
    with pytest.raises(S.ChecksumError):
        S.parse_reply(PP_REPLY.replace(b"DMIN:20;4", b"DMIN:21;4"))
    with pytest.raises(S.StatusError, match="0E") as e:
        S.parse_reply(b"XX\n0E" + bytes([S.checksum(b"0E")]) + b"\n")
    assert e.value.code == "0E"


def _block(fake: FakeHokuyo, sym: str, start: int, end: int, cluster: int = 1) -> bytes:
    echo = f"{sym}{start:04d}{end:04d}{cluster:02d}" + ("000" if sym[0] == "M" else "")
    return fake._scan_block(sym, echo, "99" if sym[0] == "M" else "00", start, end, cluster)


@pytest.mark.parametrize("sym", ["MD", "MS", "GD", "GS"])
def test_scan_replies_decode_to_the_devices_values(sym):
    fake = FakeHokuyo()
    scan = S.parse_scan(_block(fake, sym, 44, 725))
    want = fake.range_mm(np.arange(44, 726))
    if sym[1] == "S":
        want = np.minimum(want, 4095)  # 2 characters hold 12 bits
    assert scan.symbol == sym and (scan.start, scan.end, scan.cluster) == (44, 725, 1)
    np.testing.assert_array_equal(scan.ranges_mm, want)
    assert scan.intensities is None


def test_range_and_intensity_reply_and_clusters_decode():
    fake = FakeHokuyo("UST-10LX")
    scan = S.parse_scan(_block(fake, "ME", 0, 1080, 3))
    r, i = fake.values(0, 1080, 3)
    assert len(scan.ranges_mm) == 361
    np.testing.assert_array_equal(scan.ranges_mm, r)
    np.testing.assert_array_equal(scan.intensities, i)


def test_a_bad_data_line_an_error_status_and_the_acknowledgement():
    fake = FakeHokuyo()
    good = _block(fake, "MD", 44, 725)
    i = good.index(b"\n", 30) - 3  # a data character of the first data line
    bad = good[:i] + bytes([good[i] ^ 0x01]) + good[i + 1:]
    with pytest.raises(S.ChecksumError, match="line 0"):
        S.parse_scan(bad)
    with pytest.raises(S.StatusError) as e:
        S.parse_scan(b"MD0044072501000\n50" + bytes([S.checksum(b"50")]) + b"\n")
    assert e.value.code == "50" and "hardware" in str(e.value)
    assert S.parse_scan(b"MD0044072501000\n00P\n") is None  # the capture acknowledgement
    with pytest.raises(S.ScipError):
        S.parse_scan(good[:-70] + b"\n")  # truncated: fewer values than steps


def test_decode_scan_gives_si_ranges_with_inf_for_errors_and_out_of_range():
    fake, sp = FakeHokuyo(), S.SensorParams()
    msg = S.decode_scan(_block(fake, "MD", 44, 725), sp, stamp=12.5, frame_id="front_laser")
    assert isinstance(msg, LaserScan)
    assert (msg.header.stamp, msg.header.frame_id) == (12.5, "front_laser")
    assert msg.ranges.dtype == np.float32 and len(msg.ranges) == 682
    mm = fake.range_mm(np.arange(44, 726))
    bad = (mm < 20) | (mm > 5600)
    assert bad.sum() > 5 and (~bad).sum() > 500  # the doorway and the glass pane are in view
    assert np.all(np.isposinf(msg.ranges[bad]))
    np.testing.assert_allclose(msg.ranges[~bad], mm[~bad] / 1000.0, rtol=1e-6)
    assert msg.angle_min == pytest.approx(sp.angle(44))
    assert msg.angles()[-1] == pytest.approx(sp.angle(725))
    assert msg.angle_increment == pytest.approx(2 * math.pi / 1024)
    assert (msg.range_min, msg.range_max, msg.scan_time) == (0.02, 5.6, pytest.approx(0.1))
    assert msg.time_increment == pytest.approx(0.1 / 1024)


def test_clock_sync_estimates_the_offset_and_unwraps_the_24_bit_counter():
    sync = S.ClockSync(window=5)
    true_offset = 1000.0 - (S.WRAP_MS - 300) * 1e-3  # host 1000.0 s when the counter reads 2^24 - 300 ms
    samples = []
    for k in range(10):  # TM1 round trips of 2..20 ms, the sensor reading its clock mid-way
        t0 = 1000.0 + 0.02 * k
        rtt = 0.002 * (k % 5 + 1)
        samples.append((t0, round((t0 + rtt / 2 - true_offset) * 1000) % S.WRAP_MS, t0 + rtt))
    assert sync.calibrate(samples) == pytest.approx(true_offset, abs=1e-3)
    stamps = []
    for k in range(20):  # scans every 50 ms across the counter wrap, received 3 ms later
        host = 1000.3 + 0.05 * k
        raw = round((host - true_offset) * 1000) % S.WRAP_MS
        stamps.append(sync.stamp(raw, host + 0.003))
        assert stamps[-1] == pytest.approx(host, abs=2e-3)
    assert np.all(np.diff(stamps) > 0.04)


def test_clock_sync_follows_drift_and_never_stamps_after_receipt():
    sync = S.ClockSync(window=10)
    sync.calibrate([(0.0, 0, 0.002)])
    errs = []
    for k in range(400):  # the sensor clock runs 1000 ppm slow; each scan received 5 ms after it is taken
        host = 0.05 * k
        stamp = sync.stamp(round(host * (1 - 1e-3) * 1000), host + 0.005)
        assert stamp <= host + 0.005 + 1e-9
        errs.append(stamp - host)
    assert abs(errs[-1]) < 3e-3  # 20 ms of accumulated drift corrected down to the counter's resolution
