"""The Hokuyo driver against the simulated SCIP 2.0 device: over a real pty pair (URG-04LX on USB) and
over TCP (UST-10LX), the bytes crossing a kernel tty / socket as with the hardware."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from robot_side.lasers.fake_hokuyo import FakeHokuyo
from robot_side.lasers.hokuyo import HokuyoDriver, HokuyoError, HokuyoParams, open_transport
from tests.support import wait_until


@pytest.fixture
def rig():
    """make(fake_kw, tcp=False, connect=True, start=True, **params) -> (fake, driver); all closed afterwards."""
    made = []

    def make(fake_kw: dict | None = None, tcp: bool = False, connect: bool = True, start: bool = True, **params):
        if tcp:
            fake, (host, port) = FakeHokuyo.on_tcp(**{"model": "UST-10LX", **(fake_kw or {})})
            params = {"ip_address": host, "ip_port": port, **params}
        else:
            fake, path = FakeHokuyo.on_pty(**(fake_kw or {}))
            params = {"serial_port": path, **params}
        if start:
            fake.start()
        p = HokuyoParams(**params)
        scans = []
        drv = HokuyoDriver(open_transport(p), p, on_scan=scans.append)
        drv.scans = scans
        made.append((fake, drv))
        if connect:
            drv.connect()
            drv.start()
        return fake, drv

    yield make
    for fake, drv in made:
        drv.close()
        fake.close()


def _check_room(fake: FakeHokuyo, msg, cluster: int = 1) -> None:
    """Every beam equals the device's room at the beam's angle (inf where it has no valid echo)."""
    a = msg.angles()
    steps = np.rint(a / (2 * math.pi / fake.m["ares"]) + fake.m["afrt"]).astype(int)
    np.testing.assert_allclose(fake.angle(steps), a, atol=1e-9)
    mm, inten = fake.values(int(steps[0]), int(steps[-1]) + cluster - 1, cluster)
    mm = mm[:len(a)]
    valid = (mm >= 20) & (mm <= fake.m["dmax"])
    assert np.all(np.isposinf(msg.ranges[~valid]))
    np.testing.assert_allclose(msg.ranges[valid], mm[valid] / 1000.0, rtol=1e-6)
    if len(msg.intensities):
        np.testing.assert_array_equal(msg.intensities, inten[:len(a)].astype(np.float32))


def test_urg04lx_on_a_pty_streams_the_room_with_the_right_angles(rig):
    fake, drv = rig(frame_id="base_laser")
    assert drv.info.version["PROT"] == "SCIP 2.0"
    assert drv.info.sensor.ares == 1024 and (drv.info.start_step, drv.info.end_step) == (44, 725)
    assert drv.info.status["LASR"] in ("ON", "OFF")
    msg = wait_until(lambda: len(drv.scans) >= 3 and drv.scans[-1], 10, "scans")
    assert msg.header.frame_id == "base_laser" and len(msg.ranges) == 682
    assert msg.angle_min == pytest.approx(-340 * 2 * math.pi / 1024)
    assert np.isinf(msg.ranges).sum() > 5  # the doorway (error code) and the glass pane (beyond DMAX)
    _check_room(fake, msg)
    assert [c[:2] for c in fake.commands[:4]] == ["QT", "VV", "PP", "II"]
    assert fake.commands[-2:] == ["BM", "MD0044072501000"]
    assert drv.stats.bad_checksum == drv.stats.error_status == 0


def test_two_character_encoding_with_a_cropped_field_of_view(rig):
    fake, drv = rig(encoding_chars=2, angle_min=0.3, angle_max=2.0)
    msg = wait_until(lambda: drv.scans and drv.scans[-1], 10, "scans")
    assert fake.commands[-1].startswith("MS")
    assert 0.3 <= msg.angle_min < 0.3 + msg.angle_increment
    assert 2.0 - msg.angle_increment < msg.angle_max <= 2.0
    _check_room(fake, msg)


def test_ust10lx_over_tcp_with_intensity_clusters_and_skip(rig):
    fake, drv = rig(tcp=True, intensity=True, cluster=3, skip=1, angle_min=-1.0, angle_max=1.0)
    msg = wait_until(lambda: len(drv.scans) >= 2 and drv.scans[-1], 10, "scans")
    assert fake.commands[-1].startswith("ME") and fake.commands[-1][10:13] == "031"
    assert msg.angle_increment == pytest.approx(3 * 2 * math.pi / 1440)
    assert msg.scan_time == pytest.approx(2 * 60.0 / 2400)  # one rotation of two is published
    assert len(msg.intensities) == len(msg.ranges)
    _check_room(fake, msg, cluster=3)


def test_intensities_can_be_captured_but_not_published(rig):
    _, drv = rig(tcp=True, intensity=True, publish_intensity=False)
    msg = wait_until(lambda: drv.scans and drv.scans[-1], 10, "scans")
    assert len(msg.intensities) == 0 and len(msg.ranges) == 1081


def test_a_corrupt_frame_is_dropped_and_counted_and_the_stream_goes_on(rig):
    fake, drv = rig()
    wait_until(lambda: len(drv.scans) >= 2, 10, "scans")
    fake.inject("checksum")
    wait_until(lambda: drv.stats.bad_checksum == 1, 10, "the corrupt frame counted")
    n = drv.stats.scans
    wait_until(lambda: drv.stats.scans >= n + 3, 10, "scans after the corrupt frame")
    assert drv.error is None
    assert drv.stats.scans + 1 <= fake.scans_sent


def test_an_error_status_in_the_stream_is_counted_and_too_many_in_a_row_end_the_driver(rig):
    fake, drv = rig(error_limit=3)
    wait_until(lambda: drv.scans, 10, "scans")
    fake.inject("status", code="50")
    wait_until(lambda: drv.stats.error_status == 1, 10, "the error status counted")
    assert drv.stats.last_error_code == "50"
    n = drv.stats.scans
    wait_until(lambda: drv.stats.scans >= n + 2, 10, "scans after it")
    for _ in range(3):
        fake.inject("status", code="51")
    wait_until(lambda: drv.error is not None, 10, "the driver giving up")
    assert "3 bad scans in a row" in str(drv.error) and "51" in str(drv.error)


def test_garbage_bytes_between_replies_are_skipped(rig):
    fake, drv = rig()
    wait_until(lambda: drv.scans, 10, "scans")
    fake.inject("garbage", data=b"\x00\xff\x13noise")  # glued to the front of the next scan's echo
    fake.inject("garbage", data=b"line\n\nnoise\n")  # a whole bogus reply, then more
    wait_until(lambda: drv.stats.garbage_bytes >= 10, 10, "garbage counted")
    n = drv.stats.scans
    wait_until(lambda: drv.stats.scans >= n + 3, 10, "scans after the garbage")
    assert drv.stats.bad_checksum == 0 and drv.error is None


def test_an_error_reply_to_a_command_names_the_code(rig):
    _, drv = rig({"fail": {"BM": "01"}}, connect=False)
    with pytest.raises(HokuyoError, match="BM answered status 01"):
        drv.connect()
    _, drv = rig({"model": "URG-04LX"}, connect=False, intensity=True)  # no ME on a URG-04LX
    drv.connect()
    with pytest.raises(HokuyoError, match="ME answered status 0E"):
        drv.start()


def test_a_silent_port_gives_a_clear_error_naming_it(rig):
    _, drv = rig(connect=False, start=False, reply_timeout=0.2)  # a pty with nobody answering
    t0 = time.monotonic()
    with pytest.raises(HokuyoError, match="no answer") as e:
        drv.connect()
    assert drv.p.serial_port in str(e.value) and time.monotonic() - t0 < 2.0


@pytest.mark.parametrize("tcp", [False, True])
def test_unplugging_the_sensor_ends_the_driver_with_an_error(rig, tcp):
    fake, drv = rig(tcp=tcp)
    wait_until(lambda: drv.scans, 10, "scans")
    fake.unplug()
    wait_until(lambda: drv.error is not None, 10, "the driver noticing")


def test_a_single_scan_with_gd(rig):
    fake, drv = rig(connect=False)
    drv.connect()
    msg = drv.grab()
    assert fake.commands[-1] == "GD0044072501"
    _check_room(fake, msg)


def test_stamps_follow_the_host_clock_across_the_sensor_counter_wrap(rig):
    fake, drv = rig({"time_base_ms": (1 << 24) - 400})  # the 24-bit counter wraps ~0.4 s after start
    got = []
    wait_until(lambda: (got.append((time.time(), drv.last_scan)) or drv.stats.scans >= 12), 15, "1.2 s of scans")
    assert fake.now_ms() < 1 << 23  # it did wrap
    stamps = [s.header.stamp for s in drv.scans]
    assert np.all(np.diff(stamps) > 0.05) and np.all(np.diff(stamps) < 0.15)  # 10 Hz, no jump at the wrap
    assert abs(stamps[-1] - time.time()) < 0.3
    t0 = time.time()
    uncal, drv2 = rig(calibrate_time=False)
    msg = wait_until(lambda: drv2.scans and drv2.scans[-1], 10, "scans")
    assert t0 <= msg.header.stamp <= time.time()
    assert not any(c.startswith("TM") for c in uncal.commands)
