"""Semantic checks of decoded bus messages: what the codec cannot see.

The codec guarantees types and shapes; this module refuses well-formed messages no consumer could use
— NaN / Inf where a number is a position, a speed or a time (a scan's ranges and a depth image may
hold them: REP 117 and "no data"), a quaternion of zeros, a map of size 0, a scan with a zero angle
step, coordinates beyond ``MAX_COORD_M``, a transform stamped far in the future of the receiver's
clock (one such TF would push every later transform out of the cache; other stamps are not checked:
a goal from a wall-clock terminal to a simulated-time stack is fine). ``problem(msg, now)`` returns
why, or None.
``common.bus_topics.Subscription`` and ``common.tf.TFListener`` call it on every message and count
the rejects as ``invalid``.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any, Callable

import numpy as np

from common.geometry import Quaternion, Vector3
from common.messages import (
    BatteryState,
    CameraInfo,
    Clock,
    Costmap,
    DepthImage,
    Header,
    LaserScan,
    OccupancyGrid,
    Path,
    PointCloud,
    PolygonStamped,
    Pose2D,
    SpawnBox,
)

MAX_COORD_M = 1.0e6  # |x|, |y|, |z| of any position: 1000 km is no indoor robot's map
MAX_FUTURE_S = 300.0  # a transform this far ahead of the receiver's clock is refused (clock offsets are smaller)
MAX_CELLS = 100_000_000  # occupancy grids / costmaps
MAX_BEAMS = 100_000

# (type, field) whose floats may be NaN / Inf
_NONFINITE_OK = {
    (LaserScan, "ranges"), (LaserScan, "intensities"), (DepthImage, "depth"), (PointCloud, "points"),
    (BatteryState, "percentage"),
}
_FIELDS: dict[type, tuple[str, ...]] = {}


def _fields(cls: type) -> tuple[str, ...]:
    names = _FIELDS.get(cls)
    if names is None:
        names = _FIELDS[cls] = tuple(f.name for f in dataclasses.fields(cls))
    return names


def _walk(obj: Any, path: str) -> str | None:
    """Non-finite floats (outside ``_NONFINITE_OK``) and the per-type rules, depth first."""
    cls = type(obj)
    for name in _fields(cls):
        v = getattr(obj, name)
        if isinstance(v, float):
            if not math.isfinite(v) and (cls, name) not in _NONFINITE_OK:
                return f"{path}.{name} is {v}"
        elif isinstance(v, np.ndarray):
            if v.dtype.kind == "f" and (cls, name) not in _NONFINITE_OK and v.size and not np.isfinite(v).all():
                return f"{path}.{name} holds NaN / Inf"
        elif dataclasses.is_dataclass(v):
            why = _walk(v, f"{path}.{name}")
            if why:
                return why
        elif isinstance(v, tuple):
            for i, x in enumerate(v):
                if dataclasses.is_dataclass(x):
                    why = _walk(x, f"{path}.{name}[{i}]")
                    if why:
                        return why
    rule = _RULES.get(cls)
    return rule(obj, path) if rule is not None else None


def _grid(m, path: str) -> str | None:
    if not m.resolution > 0.0:
        return f"{path}.resolution {m.resolution} must be > 0"
    if m.data.shape[0] == 0 or m.data.shape[1] == 0:
        return f"{path} is a map of size {m.data.shape[1]}x{m.data.shape[0]}"
    if m.data.size > MAX_CELLS:
        return f"{path} has {m.data.size} cells (at most {MAX_CELLS})"
    return None


def _scan(s: LaserScan, path: str) -> str | None:
    n = len(s.ranges)
    if not 0 < n <= MAX_BEAMS:
        return f"{path} has {n} ranges (1..{MAX_BEAMS})"
    if s.angle_increment == 0.0:
        return f"{path}.angle_increment is 0"
    if len(s.intensities) not in (0, n):
        return f"{path} has {len(s.intensities)} intensities for {n} ranges"
    if not (0.0 <= s.range_min < s.range_max):
        return f"{path}: range_min {s.range_min}, range_max {s.range_max} (need 0 <= min < max)"
    return None


def _quaternion(q: Quaternion, path: str) -> str | None:
    if q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w < 1e-12:
        return f"{path} is a quaternion of zeros"
    return None


def _position(p, path: str) -> str | None:
    if max(abs(p.x), abs(p.y), abs(getattr(p, "z", 0.0))) > MAX_COORD_M:
        return f"{path} = ({p.x:g}, {p.y:g}) is beyond {MAX_COORD_M:g} m"
    return None


def _positive(*names: str) -> Callable[[Any, str], str | None]:
    def rule(m, path: str) -> str | None:
        for n in names:
            if not getattr(m, n) > 0:
                return f"{path}.{n} = {getattr(m, n)} must be > 0"
        return None
    return rule


def _points(cols: int, attr: str = "points", bound: bool = True) -> Callable[[Any, str], str | None]:
    """Shape check; ``bound``: also refuse coordinates beyond MAX_COORD_M (not for clouds: a VGA cloud
    would cost milliseconds, and the costmap layers cut clouds at their obstacle range anyway)."""
    def rule(m, path: str) -> str | None:
        a = getattr(m, attr)
        if a.shape[1] != cols:
            return f"{path}.{attr} has {a.shape[1]} columns, not {cols}"
        if bound and a.size and float(np.abs(a[:, :min(cols, 2)]).max()) > MAX_COORD_M:
            return f"{path}.{attr} has a point beyond {MAX_COORD_M:g} m"
        return None
    return rule


def _depth(d: DepthImage, path: str) -> str | None:
    return f"{path} is an image of size 0" if d.depth.size == 0 else None


_RULES: dict[type, Callable[[Any, str], str | None]] = {
    Header: lambda h, path: f"{path}.stamp {h.stamp} is negative" if h.stamp < 0.0 else None,
    Clock: lambda c, path: f"{path}.clock {c.clock} is negative" if c.clock < 0.0 else None,
    Quaternion: _quaternion,
    Vector3: _position,
    Pose2D: _position,
    LaserScan: _scan,
    OccupancyGrid: _grid,
    Costmap: _grid,
    DepthImage: _depth,
    CameraInfo: _positive("width", "height", "fx", "fy"),
    SpawnBox: _positive("size_x", "size_y", "height"),
    PointCloud: _points(3, bound=False),
    PolygonStamped: _points(2),
    Path: _points(3, "poses"),
}


def problem(msg: Any, now: float = 0.0) -> str | None:
    """Why ``msg`` is unusable, or None. ``now``: the receiver's clock (0 = unknown, no future check)."""
    cls = type(msg)
    if cls not in _FINE and not dataclasses.is_dataclass(msg):
        return None
    why = None if _fine_of(cls)(msg) else _walk(msg, cls.__name__)
    if why or now <= 0.0:
        return why
    for stamp in _stamps(msg):
        if stamp > now + MAX_FUTURE_S:
            return f"stamp {stamp:.3f} is {stamp - now:.0f} s ahead of this node's clock"
    return None


_FINE: dict[type, Callable[[Any], bool]] = {}
_INF = math.inf


def _make_fine(cls: type) -> Callable[[Any], bool]:
    """A straight-line ``msg -> True`` for a message that ``_walk`` would pass, generated per type from
    its declared fields; False sends the message to ``_walk``, which finds and words the problem (or
    passes it: False only means "not the common case", e.g. an int where a float is declared)."""
    hints = typing.get_type_hints(cls)
    env: dict[str, Any] = {"INF": _INF, "ndarray": np.ndarray, "isfinite": np.isfinite, "RULE": _RULES.get(cls)}
    lines = ["def fine(m):"]
    for f in dataclasses.fields(cls):
        k, ann = f.name, hints[f.name]
        lines.append(f"    x = m.{k}")
        if ann is float:
            ok = "x.__class__ is float and -INF < x < INF" if (cls, k) not in _NONFINITE_OK else "x.__class__ is float"
        elif ann in (int, str, bool):
            env[f"T_{k}"] = ann
            ok = f"x.__class__ is T_{k}"
        elif ann is np.ndarray:  # get_type_hints drops the Arr annotation
            ok = ("x.__class__ is ndarray" if (cls, k) in _NONFINITE_OK else
                  "x.__class__ is ndarray and (x.dtype.kind != 'f' or isfinite(x).all())")
        elif isinstance(ann, type) and dataclasses.is_dataclass(ann) and ann is not cls:
            env[f"T_{k}"], env[f"F_{k}"] = ann, _fine_of(ann)
            ok = f"x.__class__ is T_{k} and F_{k}(x)"
        else:  # tuples, unions...: the generic walk
            return lambda m: False
        lines += [f"    if not ({ok}):", "        return False"]
    lines.append("    return RULE is None or RULE(m, '') is None")
    exec("\n".join(lines), env)  # noqa: S102 - source built from the field names of a message dataclass
    return env["fine"]


def _fine_of(cls: type) -> Callable[[Any], bool]:
    fine = _FINE.get(cls)
    if fine is None:
        fine = _FINE[cls] = _make_fine(cls)
    return fine


def _stamps(msg: Any):
    for ts in getattr(msg, "transforms", ()):
        yield ts.header.stamp
