"""The S300 driver against the fake scanner over a real pty pair (os.openpty): the bytes cross a kernel tty
as with the RS-422 USB adapter; faults are injected at the fake."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_side.lasers.fake_s300 import FakeS300
from robot_side.lasers.s300 import S300Params
from robot_side.lasers.s300_driver import S300ConnectionError, S300Driver, open_port
from tests.support import wait_until


@pytest.fixture
def rig():
    """make(fake_kw, **params) -> (fake, driver); the fake streams, the driver reads; all closed after."""
    made = []

    def make(fake_kw: dict | None = None, **params):
        fake, path = FakeS300.on_pty(**(fake_kw or {}))
        drv = S300Driver(open_port(path), S300Params(port=path, **params))
        fake.start()
        drv.start()
        made.append((fake, drv))
        return fake, drv

    yield make
    for fake, drv in made:
        drv.close()
        fake.close()


def _scans(drv, n: int, timeout: float = 10.0) -> int:
    start = drv.scans
    wait_until(lambda: drv.scans >= start + n, timeout, f"{n} more scans (have {drv.stats()})")
    return drv.scans


def test_driver_publishes_the_fakes_room_as_541_beams(rig):
    fake, drv = rig()
    _scans(drv, 3)
    scan = drv.last_scan
    truth = fake.true_ranges()
    hit = np.isfinite(truth)
    np.testing.assert_allclose(scan.ranges[hit], truth[hit], atol=0.0051)
    assert np.all(np.isposinf(scan.ranges[~hit]))
    assert len(scan.ranges) == 541 and scan.angle_min == pytest.approx(-math.radians(135))
    assert drv.crc_errors == 0 and drv.error is None


def test_corrupt_frame_and_crc_error_are_dropped_and_counted_and_reading_continues(rig):
    fake, drv = rig()
    _scans(drv, 2)
    base_crc, dropped = drv.crc_errors, fake.bytes_dropped
    fake.inject("corrupt")
    wait_until(lambda: drv.crc_errors > base_crc, 10, "the cut-short telegram counted")
    fake.inject("crc")
    wait_until(lambda: drv.crc_errors > base_crc + 1, 10, "the bad CRC counted")
    sent = fake.scans_sent
    _scans(drv, 3)
    if fake.bytes_dropped == dropped:  # no telegram lost in the pty (a busy machine may lose one)
        assert drv.crc_errors == base_crc + 2
    assert drv.telegrams >= sent - 2 and drv.error is None


def test_garbage_between_telegrams_is_skipped_and_counted(rig):
    fake, drv = rig()
    _scans(drv, 2)
    garbage = drv.garbage_bytes
    fake.inject("garbage", 300)
    fake.inject("garbage", 77)
    wait_until(lambda: drv.garbage_bytes >= garbage + 377, 10, "the garbage counted")
    _scans(drv, 3)
    assert drv.error is None


def test_a_stream_starting_mid_telegram_is_resynchronised(rig):
    fake, drv = rig({"start_mid_telegram": True, "layout": "old"})
    _scans(drv, 3)
    tail = len(fake.telegram(0)) - len(fake.telegram(0)) // 3  # what the fake sent of its first telegram
    assert drv.garbage_bytes >= tail and drv.crc_errors == 0


def test_telegrams_of_another_device_address_are_ignored(rig):
    fake, drv = rig({"address": 8}, scan_id=7)
    wait_until(lambda: drv.other_address >= 3, 10, "telegrams of address 8 seen")
    assert drv.scans == 0


def test_unplugged_adapter_ends_the_reader_with_an_error(rig):
    fake, drv = rig()
    _scans(drv, 1)
    fake.unplug()
    wait_until(lambda: drv.error is not None, 10, "the reader's error after the unplug")


def test_opening_a_missing_port_names_it(tmp_path):
    missing = str(tmp_path / "ttyNOPE")
    with pytest.raises(S300ConnectionError, match="ttyNOPE"):
        open_port(missing)
