"""Hostile payloads for one subscribed topic, each labelled with what the receiver must do with it.

``malformed``: not a message of the topic's type — random bytes, a truncated or bit-cut encoding, another
type, the right type name with a wrong schema (missing / extra field, wrong field type, other version).
``invalid``: well formed but unusable — NaN / Inf in a field that is a number (one field at a time), a
quaternion of zeros, a map of size 0, a scan without beams or with a zero angle step, a coordinate at
1e300, a transform stamped a year ahead.
``valid``: strange but legal, sent once each — a scan all NaN / Inf (REP 117), a goal 1 km away,
cmd_vel of 100 m/s, an all-unknown map of one cell. The node must use or refuse them by its own rules
without raising.

The labels are built here from the message definitions, independently of ``common.msg_check``.
"""

from __future__ import annotations

import dataclasses
import math

import msgpack
import numpy as np

from common.codec import encode
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.messages import (
    REGISTRY,
    CameraInfo,
    Costmap,
    DepthImage,
    Header,
    LaserScan,
    OccupancyGrid,
    PointCloud,
    PoseStamped,
    TFMessage,
    TransformStamped,
    Twist,
)

# Fields where NaN / Inf carry a meaning (no return, no depth, unknown charge): not "invalid".
NONFINITE_MEANINGFUL = {("LaserScan", "ranges"), ("LaserScan", "intensities"), ("DepthImage", "depth"),
                        ("PointCloud", "points"), ("BatteryState", "percentage")}
YEAR_S = 3.15e7


def sample(cls: type, now: float):
    """A plausible valid message of ``cls``."""
    h = Header(now, "base_link")
    if cls is LaserScan:
        n = 90
        return LaserScan(h, -1.5, 1.5, 3.0 / (n - 1), 0.0, 0.1, 0.05, 8.0,
                         np.full(n, 2.0, np.float32), np.zeros(0, np.float32))
    if cls is OccupancyGrid:
        return OccupancyGrid(Header(now, "map"), 0.05, Pose2D(-1.0, -1.0, 0.0), np.zeros((40, 40), np.int8))
    if cls is Costmap:
        return Costmap(Header(now, "map"), 0.05, Pose2D(-1.0, -1.0, 0.0), np.zeros((40, 40), np.uint8))
    if cls is DepthImage:
        return DepthImage(Header(now, "camera_depth_optical_frame"), np.full((48, 64), 2.0, np.float32))
    if cls is CameraInfo:
        return CameraInfo(Header(now, "camera_depth_optical_frame"), 64, 48, 57.5, 57.5, 31.5, 23.5)
    if cls is PointCloud:
        return PointCloud(Header(now, "base_link"), np.array([[1.0, 0.0, 0.3], [1.5, 0.2, 0.1]], np.float32))
    if cls is TFMessage:
        return TFMessage((TransformStamped(Header(now, "fuzz_parent"), "fuzz_child", Transform()),))
    if cls is PoseStamped:
        return PoseStamped(Header(now, "map"), Pose2D(0.5, 0.0, 0.0).to_transform())
    fields = {f.name for f in dataclasses.fields(cls)}
    return cls(header=h) if "header" in fields else cls()


def _nan_variants(msg, path=()):
    """(label path, message) with one float field (or one array element) set to NaN, +Inf and -Inf."""
    cls = type(msg)
    for f in dataclasses.fields(cls):
        v = getattr(msg, f.name)
        meaningful = (cls._msg_name, f.name) in NONFINITE_MEANINGFUL
        if isinstance(v, float) and not meaningful:
            for bad in (math.nan, math.inf, -math.inf):
                yield (*path, f.name), dataclasses.replace(msg, **{f.name: bad})
        elif isinstance(v, np.ndarray) and v.dtype.kind == "f" and v.size and not meaningful:
            a = v.copy()
            a.flat[a.size // 2] = np.nan
            yield (*path, f.name), dataclasses.replace(msg, **{f.name: a})
        elif dataclasses.is_dataclass(v):
            for p, sub in _nan_variants(v, (*path, f.name)):
                yield p, dataclasses.replace(msg, **{f.name: sub})
        elif isinstance(v, tuple) and v and dataclasses.is_dataclass(v[0]):
            for p, sub in _nan_variants(v[0], (*path, f.name, 0)):
                yield p, dataclasses.replace(msg, **{f.name: (sub, *v[1:])})


def _replace_all(msg, cls: type, fn):
    """``msg`` with every nested ``cls`` value replaced by ``fn(value)``; None if it has none."""
    hit = False

    def go(m):
        nonlocal hit
        if isinstance(m, cls):
            hit = True
            return fn(m)
        if dataclasses.is_dataclass(m):
            return dataclasses.replace(m, **{f.name: go(getattr(m, f.name)) for f in dataclasses.fields(m)})
        if isinstance(m, tuple):
            return tuple(go(x) for x in m)
        return m

    out = go(msg)
    return out if hit else None


def semantic(msg, now: float) -> tuple[list[bytes], list[bytes]]:
    """(invalid, valid) encodings derived from a valid ``msg``."""
    invalid = [encode(m) for _, m in _nan_variants(msg)]
    for cls, fn in ((Quaternion, lambda q: Quaternion(0.0, 0.0, 0.0, 0.0)),
                    (Vector3, lambda v: Vector3(1e300, v.y, v.z)),
                    (Pose2D, lambda p: Pose2D(p.x, -1e300, p.theta))):
        m = _replace_all(msg, cls, fn)
        if m is not None:
            invalid.append(encode(m))
    valid: list[bytes] = []
    if isinstance(msg, LaserScan):
        n = len(msg.ranges)
        invalid += [encode(dataclasses.replace(msg, ranges=np.zeros(0, np.float32))),
                    encode(dataclasses.replace(msg, angle_increment=0.0)),
                    encode(dataclasses.replace(msg, range_min=5.0, range_max=1.0)),
                    encode(dataclasses.replace(msg, intensities=np.ones(n + 3, np.float32)))]
        valid += [encode(dataclasses.replace(msg, ranges=np.full(n, v, np.float32))) for v in (np.nan, np.inf, -np.inf)]
        valid.append(encode(dataclasses.replace(msg, ranges=np.full(n, 0.01, np.float32))))  # all below range_min
    if isinstance(msg, (OccupancyGrid, Costmap)):
        dt = msg.data.dtype
        invalid += [encode(dataclasses.replace(msg, data=np.zeros(s, dt))) for s in ((0, 0), (0, 5), (5, 0))]
        invalid.append(encode(dataclasses.replace(msg, resolution=0.0)))
        invalid.append(encode(dataclasses.replace(msg, resolution=-0.05)))
        valid.append(encode(dataclasses.replace(msg, data=np.full((1, 1), -1 if dt == np.int8 else 255, dt))))
    if isinstance(msg, DepthImage):
        invalid.append(encode(dataclasses.replace(msg, depth=np.zeros((0, 0), np.float32))))
        valid.append(encode(dataclasses.replace(msg, depth=np.full(msg.depth.shape, np.nan, np.float32))))
        valid.append(encode(dataclasses.replace(msg, depth=np.full((480, 2), 1.0, np.float32))))  # wrong size
    if isinstance(msg, CameraInfo):
        invalid += [encode(dataclasses.replace(msg, width=0)), encode(dataclasses.replace(msg, fx=0.0)),
                    encode(dataclasses.replace(msg, fy=-1.0))]
    if isinstance(msg, PointCloud):
        invalid.append(encode(dataclasses.replace(msg, points=np.zeros((3, 2), np.float32))))
        valid.append(encode(dataclasses.replace(msg, points=np.full((5, 3), np.nan, np.float32))))
        valid.append(encode(dataclasses.replace(msg, points=np.zeros((0, 3), np.float32))))
    if isinstance(msg, TFMessage):
        ts = msg.transforms[0]
        invalid.append(encode(TFMessage((dataclasses.replace(ts, header=Header(now + YEAR_S, "fuzz_parent")),))))
        invalid.append(encode(TFMessage((dataclasses.replace(ts, child_frame_id="fuzz_parent"),))))
        invalid.append(encode(TFMessage((dataclasses.replace(ts, child_frame_id=""),))))
    if isinstance(msg, PoseStamped):
        valid.append(encode(PoseStamped(Header(now, "map"), Pose2D(1000.0, -1000.0, 0.0).to_transform())))
        valid.append(encode(PoseStamped(Header(now, "no_such_frame"), Pose2D(1.0, 0.0, 0.0).to_transform())))
    if isinstance(msg, Twist):
        valid += [encode(Twist.planar(100.0, 50.0)), encode(Twist.planar(-100.0, -50.0))]
    return invalid, valid


def malformed(msg, rng: np.random.Generator, any_type: bool) -> list[bytes]:
    """Payloads that are not ``type(msg)``. ``any_type``: the topic takes every type (then another
    registered type is a valid message, not included)."""
    good = encode(msg)
    name, version = type(msg)._msg_name, type(msg)._msg_version
    body = msgpack.unpackb(good, raw=False, strict_map_key=False)[3]
    out = [b"", b"\x00", b"\xc1", good[: len(good) // 2], good[:-1], good + b"\x00",
           msgpack.packb(["zenav", name, version, None]), msgpack.packb(["zenav", name, version + 1, body]),
           msgpack.packb(["zenav", name]), msgpack.packb(["ros", name, version, body]),
           msgpack.packb(["zenav", name, version, {**body, "extra_field": 1}], use_bin_type=True),
           msgpack.packb({"zenav": name}), msgpack.packb("zenav"), msgpack.packb(list(range(100)))]
    for key in body:
        cut = dict(body)
        del cut[key]
        out.append(msgpack.packb(["zenav", name, version, cut], use_bin_type=True))
        for wrong in ("text", [1, 2, 3], {"a": 1}, True, None):
            if type(wrong) is not type(body[key]):
                out.append(msgpack.packb(["zenav", name, version, {**body, key: wrong}], use_bin_type=True))
    for _ in range(8):
        out.append(rng.bytes(int(rng.integers(1, 300))))
    if not any_type:
        others = [s.cls for n, s in sorted(REGISTRY.items()) if s.cls is not type(msg) and n not in ("Vector3",)]
        for cls in others[:: max(1, len(others) // 8)]:
            try:
                out.append(encode(sample(cls, 0.0)))
            except Exception:  # noqa: BLE001 - a type without defaults: not needed here
                continue
    return out


def payloads(cls: type | None, n: int, now: float, seed: int = 0) -> tuple[list[bytes], dict[str, int]]:
    """``n`` hostile payloads for a topic of type ``cls`` (None = any type) and how many of each label:
    every valid / invalid / malformed kind once, then malformed and invalid kinds repeated to ``n``."""
    rng = np.random.default_rng(seed)
    msg = sample(cls if cls is not None else Twist, now)
    bad = malformed(msg, rng, any_type=cls is None)
    invalid, valid = semantic(msg, now)
    if cls is None:  # any type is taken (move_base/cancel): only undecodable payloads are malformed
        bad = [b for b in bad if not _decodes(b)]
    out, labels = list(valid), {"valid": len(valid), "invalid": 0, "malformed": 0}
    pool = [(b, "malformed") for b in bad] + [(b, "invalid") for b in invalid]
    i = 0
    while len(out) < n:
        b, label = pool[i % len(pool)] if i < len(pool) else pool[int(rng.integers(len(pool)))]
        out.append(b)
        labels[label] += 1
        i += 1
    return out, labels


def _decodes(b: bytes) -> bool:
    from common.codec import DecodeError, decode
    try:
        decode(b)
        return True
    except DecodeError:
        return False
