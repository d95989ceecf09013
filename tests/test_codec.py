"""Codec properties: every registered message type round-trips; every bad payload is a DecodeError.

Strategies are built from the dataclass annotations, so a newly registered message type is covered
without touching this file.
"""

from __future__ import annotations

import contextlib
import dataclasses
import struct
import types
import typing
from dataclasses import dataclass

import msgpack
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from common.codec import DecodeError, EncodeError, decode, encode
from common.messages import REGISTRY, Arr, Header, LaserScan, Text, msg_equal

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

INTS = st.integers(min_value=-(2**63), max_value=2**64 - 1)  # what msgpack can carry
FLOATS = st.floats(allow_nan=True, allow_infinity=True)


def strategy_for(ann, depth: int = 0) -> st.SearchStrategy:
    """A strategy producing values of annotation ``ann`` (message classes included)."""
    origin = typing.get_origin(ann)
    if origin is typing.Annotated:
        spec = next((m for m in ann.__metadata__ if isinstance(m, Arr)), None)
        if spec is not None:
            return hnp.arrays(
                np.dtype(spec.dtype),
                hnp.array_shapes(min_dims=spec.ndim, max_dims=spec.ndim, min_side=0, max_side=6),
            )
        return strategy_for(typing.get_args(ann)[0], depth)
    if origin is tuple:
        args = typing.get_args(ann)
        if len(args) == 2 and args[1] is Ellipsis:
            return st.lists(strategy_for(args[0], depth + 1), max_size=3 if depth < 2 else 1).map(tuple)
        return st.tuples(*(strategy_for(a, depth + 1) for a in args))
    if origin in (typing.Union, types.UnionType):
        return st.one_of(*(strategy_for(a, depth) for a in typing.get_args(ann)))
    if ann is type(None):
        return st.none()
    simple = {float: FLOATS, int: INTS, bool: st.booleans(), str: st.text(max_size=20)}
    if ann in simple:
        return simple[ann]
    name = getattr(ann, "_msg_name", None)
    if name is not None:
        return message_strategy(name, depth + 1)
    raise TypeError(f"no strategy for field type {ann!r} — extend strategy_for")


def message_strategy(name: str, depth: int = 0) -> st.SearchStrategy:
    schema = REGISTRY[name]

    @st.composite
    def build(draw):
        kwargs = {k: draw(strategy_for(ann, depth)) for k, ann in schema.fields.items()}
        try:
            return schema.cls(**kwargs)
        except (TypeError, ValueError):  # a type whose constructor validates: skip those values
            assume(False)

    return build()


ALL_TYPES = sorted(REGISTRY)


def test_registry_has_the_issue_message_types():
    for name in (
        "Header",
        "Pose2D",
        "Transform",
        "Twist",
        "Odometry",
        "LaserScan",
        "DepthImage",
        "CameraInfo",
        "PointCloud",
        "OccupancyGrid",
        "Costmap",
        "Path",
        "PoseStamped",
        "TFMessage",
        "GoalStatus",
        "MotorState",
        "BatteryState",
        "Clock",
    ):
        assert name in REGISTRY


@pytest.mark.parametrize("name", ALL_TYPES)
def test_every_message_type_round_trips(name):
    @SETTINGS
    @given(message_strategy(name))
    def check(msg):
        data = encode(msg)
        assert isinstance(data, bytes)
        back = decode(data)
        assert type(back) is type(msg)
        assert msg_equal(back, msg), (msg, back)
        assert msg_equal(decode(data, type(msg)), msg)

    check()


@pytest.mark.parametrize("name", ALL_TYPES)
def test_decoding_as_another_type_is_a_decode_error(name):
    cls = REGISTRY[name].cls
    other = REGISTRY["Text" if name != "Text" else "Header"].cls
    with pytest.raises(DecodeError, match="expected"):
        decode(encode(cls()), other)


@SETTINGS
@given(st.binary(max_size=2000))
def test_random_bytes_are_decode_errors(data):
    with pytest.raises(DecodeError):
        decode(data)


@SETTINGS
@given(st.sampled_from(ALL_TYPES).flatmap(message_strategy), st.data())
def test_truncated_payloads_are_decode_errors(msg, data):
    payload = encode(msg)
    cut = data.draw(st.integers(0, len(payload) - 1))
    with pytest.raises(DecodeError):
        decode(payload[:cut])


@SETTINGS
@given(st.sampled_from(ALL_TYPES).flatmap(message_strategy), st.data())
def test_corrupted_payloads_decode_or_raise_decode_error_only(msg, data):
    payload = bytearray(encode(msg))
    for _ in range(data.draw(st.integers(1, 8))):
        i = data.draw(st.integers(0, len(payload) - 1))
        payload[i] = data.draw(st.integers(0, 255))
    with contextlib.suppress(DecodeError):  # anything else propagates and fails the test
        decode(bytes(payload))


MSGPACK_VALUES = st.recursive(
    st.none() | st.booleans() | INTS | FLOATS | st.text(max_size=10) | st.binary(max_size=10),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=20,
)


@SETTINGS
@given(st.sampled_from(ALL_TYPES), MSGPACK_VALUES, st.data())
def test_arbitrary_msgpack_bodies_decode_to_a_valid_message_or_raise_decode_error(name, junk, data):
    fields = list(REGISTRY[name].fields)
    body = {k: junk for k in fields} if fields and data.draw(st.booleans()) else junk
    payload = msgpack.packb(["zenav", name, REGISTRY[name].version, body], use_bin_type=True)
    try:
        msg = decode(payload)
    except DecodeError:
        return
    # Accepted (e.g. Pose2D with every field 0): then it is a proper message that re-encodes.
    assert type(msg) is REGISTRY[name].cls
    assert msg_equal(decode(encode(msg)), msg)


def _ext(dtype: str, shape, body: bytes, ndim: int | None = None) -> msgpack.ExtType:
    nd = len(shape) if ndim is None else ndim
    head = struct.pack("<BB", len(dtype), nd) + dtype.encode() + struct.pack(f"<{len(shape)}Q", *shape)
    return msgpack.ExtType(1, head + body)


def _scan_with(ranges) -> bytes:
    body = msgpack.unpackb(encode(LaserScan()), raw=False, ext_hook=lambda c, d: msgpack.ExtType(c, d))[3]
    body["ranges"] = ranges
    return msgpack.packb(["zenav", "LaserScan", 1, body], use_bin_type=True)


@pytest.mark.parametrize(
    "payload",
    [
        b"",
        b"\xc1",
        b"\x90",
        b"\x94",
        msgpack.packb(None),
        msgpack.packb(["zenav"]),
        msgpack.packb(["nope", "LaserScan", 1, {}]),
        msgpack.packb(["zenav", "LaserScan", 2, {}]),
        msgpack.packb(["zenav", "LaserScan", "1", {}]),
        msgpack.packb(["zenav", "NoSuchType", 1, {}]),
        msgpack.packb(["zenav", ["LaserScan"], 1, {}]),
        msgpack.packb(["zenav", "LaserScan", 1, {}, "extra"]),
        msgpack.packb({1: 2}),
        b"\x94\xa5zenav\xa4Text\x01\xdf\xff\xff\xff\xff",  # huge declared map
        b"\xdd\xff\xff\xff\xff",
        b"\xc6\xff\xff\xff\xff",
        b"\xc9\xff\xff\xff\xff\x01",  # huge array/bin/ext
        b"\x91" * 5000 + b"\xc0",  # deep nesting
        _scan_with(_ext("float32", (2**62,), b"")),
        _scan_with(_ext("float32", (2**40, 2**40), b"\0" * 8)),
        _scan_with(_ext("float32", (0, 2**63), b"")),
        _scan_with(_ext("object", (1,), b"\0" * 8)),
        _scan_with(_ext("float32", (3,), b"\0" * 11)),
        _scan_with(_ext("float32", (1,) * 5, b"\0" * 4)),
        _scan_with(_ext("float32", (2,), b"\0" * 8, ndim=9)),
        _scan_with(msgpack.ExtType(1, b"\x07")),
        _scan_with(msgpack.ExtType(9, b"\0" * 8)),
        _scan_with(_ext("float64", (2,), b"\0" * 16)),
        _scan_with(_ext("float32", (2, 2), b"\0" * 16)),
        _scan_with([1.0, 2.0]),
        msgpack.packb(["zenav", "Text", 1, {"header": {"stamp": 0.0, "frame_id": ""}, "data": b"\xff"}]),
        b"\x94\xa5zenav\xa4Text\x01\x82\xa6header\x82\xa5stamp\xcb" + b"\0" * 8 + b"\xa8frame_id\xa1\xff",
    ],
    ids=lambda p: p[:12].hex() or "empty",
)
def test_hostile_payloads_raise_decode_error_and_nothing_else(payload):
    with pytest.raises(DecodeError):
        decode(payload, LaserScan)
    with pytest.raises(DecodeError):
        decode(payload)


@dataclass(frozen=True)
class NotRegistered:
    x: float = 0.0


@pytest.mark.parametrize("obj", [NotRegistered(), object(), {"x": 1}, [1, 2], None, 3.0, "text", Header])
def test_encoding_an_unregistered_object_is_an_encode_error(obj):
    with pytest.raises(EncodeError):
        encode(obj)


@pytest.mark.parametrize(
    "msg",
    [
        LaserScan(ranges=np.zeros(3, np.float64)),  # wrong dtype: every receiver would reject it
        LaserScan(ranges=np.zeros((3, 1), np.float32)),  # wrong ndim
        LaserScan(ranges=[1.0, 2.0]),  # not an array
        LaserScan(ranges=np.array([object()] * 3)),  # would send raw pointers
        Text(data=NotRegistered()),  # unencodable field value
        Text(data="\ud800"),  # lone surrogate: not UTF-8
        Header(stamp=2**70),  # int beyond 64 bits
    ],
)
def test_encoding_a_message_with_bad_fields_is_an_encode_error(msg):
    with pytest.raises(EncodeError):
        encode(msg)


def test_decoded_arrays_are_exact_and_independent_of_byte_order():
    big = np.arange(6, dtype=">f4").reshape(2, 3)  # big-endian input
    msg = REGISTRY["DepthImage"].cls(Header(1.5, "cam"), big.astype(np.float32))
    back = decode(encode(dataclasses.replace(msg, depth=big)), type(msg))
    assert back.depth.dtype == np.float32
    assert back.depth.tolist() == big.tolist()
