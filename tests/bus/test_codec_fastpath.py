"""The codec's per-type compiled encoders / decoders keep the wire format and every check of the
generic walk they replaced (bench/bus.py: scan_p50_ms)."""

from __future__ import annotations

import struct

import msgpack
import numpy as np
import pytest

from common.codec import DecodeError, EncodeError, decode, encode
from common.geometry import Transform
from common.messages import Header, LaserScan, OccupancyGrid, Odometry, TFMessage, TransformStamped


def _ext(a: np.ndarray) -> msgpack.ExtType:
    name = a.dtype.name.encode()
    head = struct.pack(f"<BB{len(name)}s{a.ndim}Q", len(name), a.ndim, name, *a.shape)
    return msgpack.ExtType(1, head + a.astype(a.dtype.newbyteorder("<")).tobytes())


def test_the_wire_format_is_unchanged():
    r = np.arange(5, dtype=np.float32)
    m = LaserScan(Header(1.5, "laser"), -1.0, 1.0, 0.5, 0.0, 0.1, 0.05, 30.0, r, np.zeros(0, np.float32))
    body = {"header": {"stamp": 1.5, "frame_id": "laser"}, "angle_min": -1.0, "angle_max": 1.0,
            "angle_increment": 0.5, "time_increment": 0.0, "scan_time": 0.1, "range_min": 0.05,
            "range_max": 30.0, "ranges": _ext(r), "intensities": _ext(np.zeros(0, np.float32))}
    assert encode(m) == msgpack.packb(["zenav", "LaserScan", 1, body], use_bin_type=True)


def test_arrays_round_trip_whatever_their_layout_or_byte_order():
    data = np.arange(12, dtype=np.int8).reshape(3, 4)
    for a in (data, data.T, data[:, ::2], data.astype(">i1")):
        out = decode(encode(OccupancyGrid(Header(), 0.05, data=np.asarray(a, np.int8))), OccupancyGrid)
        assert np.array_equal(out.data, a) and out.data.dtype == np.int8
    big = np.arange(4, dtype=">f4")
    m = LaserScan(Header(), 0, 1, 0.1, 0, 0, 0, 1, big, np.zeros(0, np.float32))
    assert np.array_equal(decode(encode(m)).ranges, [0, 1, 2, 3])


def test_numpy_scalars_and_wrong_arrays_on_encode():
    m = decode(encode(LaserScan(Header(np.float32(2.5), "l"), np.float64(-1), 1, 0.1, 0, 0, 0, 1,
                                np.zeros(3, np.float32), np.zeros(0, np.float32))))
    assert m.header.stamp == 2.5 and type(m.angle_min) is float
    with pytest.raises(EncodeError, match=r"LaserScan.ranges: expected float32\[1d\] array, got float64\[1d\]"):
        encode(LaserScan(ranges=np.zeros(3)))
    with pytest.raises(EncodeError, match="got list"):
        encode(LaserScan(ranges=[1.0]))
    with pytest.raises(EncodeError, match="not allowed"):
        encode(LaserScan(Header(), intensities=np.zeros(1, np.float32), ranges=np.zeros(1, np.float32),
                         angle_min=np.array([object()])))


def _raw(name: str, body: dict) -> bytes:
    return msgpack.packb(["zenav", name, 1, body], use_bin_type=True)


def _odom_body() -> dict:
    return msgpack.unpackb(encode(Odometry()), raw=False)[3]


@pytest.mark.parametrize(("path", "value", "why"), [
    (("header", "stamp"), "1.0", "Odometry.header.stamp: expected float"),
    (("header", "stamp"), True, "Odometry.header.stamp: expected float"),
    (("header", "frame_id"), 3, "Odometry.header.frame_id: expected str"),
    (("pose", "rotation"), [1, 2], "Odometry.pose.rotation: expected map"),
    (("twist",), None, "Odometry.twist: expected map"),
])
def test_decode_errors_name_the_field(path, value, why):
    body = _odom_body()
    d = body
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value
    with pytest.raises(DecodeError) as e:
        decode(_raw("Odometry", body), Odometry)
    assert str(e.value).startswith(why)


def test_decode_checks_fields_items_and_array_dtypes():
    body = _odom_body()
    body["extra"] = 1
    with pytest.raises(DecodeError, match="fields"):
        decode(_raw("Odometry", body))
    tf = msgpack.unpackb(encode(TFMessage((TransformStamped(Header(), "a", Transform()),) * 2)), raw=False)[3]
    tf["transforms"][1]["child_frame_id"] = 7
    with pytest.raises(DecodeError, match=r"TFMessage.transforms\[1\].child_frame_id: expected str"):
        decode(_raw("TFMessage", tf))
    scan = msgpack.unpackb(encode(LaserScan(ranges=np.zeros(2, np.float32))), raw=False,
                           ext_hook=lambda c, d: msgpack.ExtType(c, d))[3]
    scan["ranges"] = _ext(np.zeros(2, np.float64))
    with pytest.raises(DecodeError, match=r"LaserScan.ranges: expected float32\[1d\], got float64\[1d\]"):
        decode(_raw("LaserScan", scan))
    scan["ranges"] = 1.0
    with pytest.raises(DecodeError, match="LaserScan.ranges: expected array"):
        decode(_raw("LaserScan", scan))
    assert decode(_raw("Odometry", {**_odom_body(), "child_frame_id": "b"})).child_frame_id == "b"
