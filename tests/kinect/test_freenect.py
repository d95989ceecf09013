"""The pure Kinect frame conversion and the ctypes binding (against the fake libfreenect_sync)."""

from __future__ import annotations

import numpy as np
import pytest

from common.config import ConfigError
from robot_side.kinect import freenect as F


def _frame() -> np.ndarray:
    raw = np.full((480, 640), 2000, np.uint16)
    raw[:, :8] = 0
    raw[100, 300] = 1234
    return raw


def test_millimetres_become_metres_and_no_reading_stays_invalid():
    m = F.mm_to_metres(_frame())
    assert m.dtype == np.float32 and m.shape == (480, 640)
    assert m[100, 300] == pytest.approx(1.234)
    assert m[0, 100] == pytest.approx(2.0)
    assert (m[:, :8] == 0).all()


def test_conversion_copies_the_library_buffer():
    raw = _frame()
    m = F.mm_to_metres(raw)
    raw[:] = 500
    assert m[0, 100] == pytest.approx(2.0)


@pytest.mark.parametrize(("mode", "shape"), [(2, (480, 640)), (5, (240, 320)), (8, (120, 160))])
def test_depth_modes_decimate_and_scale_the_intrinsics(mode, shape):
    p = F.KinectParams(depth_mode=mode)
    img = F.depth_image(_frame(), p, 3.0)
    info = F.camera_info(p, 3.0)
    assert img.depth.shape == shape == (info.height, info.width)
    assert img.header == info.header and img.header.frame_id == "camera_depth_optical_frame"
    step = 640 // shape[1]
    assert info.fx == info.fy == pytest.approx(575.8 / step, abs=0.05)
    # the decimated pixel u' is VGA pixel step * u': the same ray through both intrinsics
    u = 100
    assert (u - info.cx) / info.fx == pytest.approx((step * u - 319.5) / 575.816, rel=1e-4)
    if step > 1:
        assert img.depth[100 // step, 300 // step] == pytest.approx(1.234)


def test_registered_depth_uses_the_rgb_camera():
    p = F.KinectParams(depth_registration=True)
    info = F.camera_info(p)
    assert info.fx == 525.0 and info.header.frame_id == "camera_rgb_optical_frame"
    assert p.depth_format == F.FREENECT_DEPTH_REGISTERED
    assert F.KinectParams().depth_format == F.FREENECT_DEPTH_MM


def test_params_take_the_openni_names_and_report_bad_values():
    p = F.load_kinect_params({"depth_mode": 5, "data_skip": 1, "depth_registration": False}, "k.yaml")
    assert p.publish_rate == pytest.approx(15.0)
    with pytest.raises(ConfigError, match="depth_mode") as e:
        F.load_kinect_params({"depth_mode": 3, "data_skp": 1}, "k.yaml")
    assert "data_skip" in str(e.value)  # the did-you-mean of the second problem


def test_binding_reads_frames_from_the_library(fake_lib, monkeypatch):
    monkeypatch.delenv("FAKE_FREENECT_NO_DEVICE", raising=False)
    monkeypatch.delenv("FAKE_FREENECT_UNPLUG_FILE", raising=False)
    lib = F.FreenectSync(fake_lib)
    raw, ts1 = lib.get_depth(0, F.FREENECT_DEPTH_MM)
    assert raw.shape == (480, 640) and raw.dtype == np.uint16
    assert raw[0, 100] == 2000 and raw[479, 300] == 1000 and raw[0, 0] == 0
    _, ts2 = lib.get_depth(0, F.FREENECT_DEPTH_MM)
    assert ts2 > ts1
    with pytest.raises(F.FreenectError, match="index 3"):
        lib.get_depth(3, F.FREENECT_DEPTH_MM)
    lib.stop()


def test_missing_library_is_reported_as_unavailable(tmp_path):
    with pytest.raises(F.LibraryUnavailable):
        F.FreenectSync(str(tmp_path / "libfreenect_sync.so.0.5"))
    with pytest.raises(F.LibraryUnavailable):
        F.FreenectSync("libc.so.6")   # loads, but has no sync API
