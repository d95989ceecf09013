"""TFBuffer: a tree of coordinate frames with a time history per edge (pure; no bus, no zenoh).

Like tf2's BufferCore: each child frame has one parent; an edge keeps the transforms of the last
``cache_time`` seconds (by stamp) and is interpolated between samples (linear translation, slerp
rotation). Static edges hold one transform valid at every time. ``lookup(target, source)`` composes
along the tree through the common ancestor and returns a ``TransformStamped`` whose transform maps
``source`` coordinates into ``target`` (header.frame_id = target, child_frame_id = source).
Time 0.0 means "the latest time at which every edge of the path has data" (ROS ``Time(0)``).
"""

from __future__ import annotations

import bisect
import math
import threading
from dataclasses import dataclass, field

import numpy as np

from common.clock import WallClock
from common.config import strip_frame
from common.geometry import Pose2D, Transform, Vector3, slerp
from common.messages import Header, TransformStamped

__all__ = ["TFBuffer", "TFError", "UnknownFrameError", "ConnectivityError", "ExtrapolationError", "EdgeInfo"]


class TFError(LookupError):
    """Base of every lookup failure (a ``LookupError``)."""


class UnknownFrameError(TFError):
    """A frame id nobody has published."""


class ConnectivityError(TFError):
    """Both frames exist but lie in different trees."""


class ExtrapolationError(TFError):
    """The requested time lies outside an edge's history (by more than the tolerance)."""


@dataclass(frozen=True)
class EdgeInfo:
    """What ``tf tree`` shows about one parent -> child edge."""

    parent: str
    child: str
    static: bool
    publisher: str  # node name of the last publisher ("" if unknown)
    rate_hz: float  # average over the cached history (0 for static / single sample)
    latest_stamp: float
    oldest_stamp: float
    age: float  # clock.now() - latest_stamp (0 for static)
    received: int  # transforms received on this edge


@dataclass
class _Edge:
    parent: str
    static: bool = False
    stamps: list[float] = field(default_factory=list)
    tfs: list[Transform] = field(default_factory=list)
    publisher: str = ""
    received: int = 0


def _interpolate(a: Transform, b: Transform, s: float) -> Transform:
    ta, tb = a.translation, b.translation
    t = Vector3(ta.x + s * (tb.x - ta.x), ta.y + s * (tb.y - ta.y), ta.z + s * (tb.z - ta.z))
    return Transform(t, slerp(a.rotation, b.rotation, s))


def _check_transform(tr: Transform) -> Transform:
    vals = (tr.translation.x, tr.translation.y, tr.translation.z, *tr.rotation.as_array())
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"transform has a non-finite value: {tr}")
    return Transform(tr.translation, tr.rotation.normalized())


class TFBuffer:
    """Thread-safe transform buffer. ``clock`` (``now()``, ``simulated``) gives ages and the time base of
    lookup timeouts (a node's clock: wall or simulated). ``tolerance`` (s) allows a lookup slightly
    before/after an edge's history, using its first/last sample."""

    def __init__(self, cache_time: float = 10.0, clock=None, tolerance: float = 0.0) -> None:
        if cache_time <= 0:
            raise ValueError("cache_time must be > 0")
        self.cache_time, self.tolerance = float(cache_time), float(tolerance)
        self.clock = clock if clock is not None else WallClock()
        self._edges: dict[str, _Edge] = {}  # child -> edge to its parent
        self._cv = threading.Condition()
        self.parent_changes = 0  # times a frame was re-parented (the old history is dropped)

    # -- filling -------------------------------------------------------------------------------
    def set_transform(self, ts: TransformStamped, authority: str = "", static: bool = False) -> None:
        """Add one stamped transform (parent = header.frame_id). Raises ValueError if malformed."""
        parent, child = strip_frame(ts.header.frame_id), strip_frame(ts.child_frame_id)
        if not parent or not child:
            raise ValueError(f"empty frame id in transform {parent!r} -> {child!r}")
        if parent == child:
            raise ValueError(f"transform from frame {child!r} to itself")
        tr, stamp = _check_transform(ts.transform), float(ts.header.stamp)
        with self._cv:
            e = self._edges.get(child)
            if e is None or e.parent != parent or e.static != static:
                if e is not None and e.parent != parent:
                    self.parent_changes += 1
                e = self._edges[child] = _Edge(parent, static)
            e.publisher, e.received = authority or e.publisher, e.received + 1
            if static:
                e.stamps, e.tfs = [stamp], [tr]
            elif not e.stamps or stamp >= e.stamps[-1] - self.cache_time:
                i = bisect.bisect_left(e.stamps, stamp)
                if i < len(e.stamps) and e.stamps[i] == stamp:
                    e.tfs[i] = tr
                else:
                    e.stamps.insert(i, stamp)
                    e.tfs.insert(i, tr)
                cut = bisect.bisect_left(e.stamps, e.stamps[-1] - self.cache_time)
                if cut:
                    del e.stamps[:cut], e.tfs[:cut]
            self._cv.notify_all()

    def set_transforms(self, transforms, authority: str = "", static: bool = False) -> None:
        for ts in transforms:
            self.set_transform(ts, authority, static)

    def clear(self) -> None:
        """Forget every non-static transform (e.g. after simulated time jumped backwards)."""
        with self._cv:
            self._edges = {c: e for c, e in self._edges.items() if e.static}
            self._cv.notify_all()

    # -- the tree ------------------------------------------------------------------------------
    def frames(self) -> list[str]:
        with self._cv:
            return sorted(set(self._edges) | {e.parent for e in self._edges.values()})

    def parent(self, frame: str) -> str | None:
        with self._cv:
            e = self._edges.get(strip_frame(frame))
            return e.parent if e else None

    def edges(self) -> list[EdgeInfo]:
        """One ``EdgeInfo`` per parent -> child edge, sorted by (parent, child)."""
        now = self.clock.now()
        with self._cv:
            out = []
            for child, e in self._edges.items():
                n, first, last = len(e.stamps), e.stamps[0], e.stamps[-1]
                rate = (n - 1) / (last - first) if not e.static and n > 1 and last > first else 0.0
                out.append(EdgeInfo(e.parent, child, e.static, e.publisher, rate, last, first,
                                    0.0 if e.static else now - last, e.received))
        return sorted(out, key=lambda i: (i.parent, i.child))

    def _chain(self, frame: str) -> list[str]:
        """frame, its parent, ... up to the root (cycle-safe)."""
        chain, seen = [frame], {frame}
        while (e := self._edges.get(chain[-1])) is not None and e.parent not in seen:
            chain.append(e.parent)
            seen.add(e.parent)
        return chain

    # -- lookup --------------------------------------------------------------------------------
    def _edge_at(self, child: str, t: float) -> Transform:
        e = self._edges[child]
        if e.static:
            return e.tfs[0]
        st = e.stamps
        if t > st[-1]:
            if t - st[-1] <= self.tolerance:
                return e.tfs[-1]
            raise ExtrapolationError(
                f"lookup would require extrapolation {t - st[-1]:.4f} s into the future on edge "
                f"{e.parent} -> {child}: requested time {t:.4f}, latest data at {st[-1]:.4f}")
        if t < st[0]:
            if st[0] - t <= self.tolerance:
                return e.tfs[0]
            raise ExtrapolationError(
                f"lookup would require extrapolation {st[0] - t:.4f} s into the past on edge "
                f"{e.parent} -> {child}: requested time {t:.4f}, earliest data at {st[0]:.4f}")
        i = bisect.bisect_left(st, t)
        if st[i] == t:
            return e.tfs[i]
        s = (t - st[i - 1]) / (st[i] - st[i - 1])
        return _interpolate(e.tfs[i - 1], e.tfs[i], s)

    def _lookup_now(self, target: str, source: str, time: float) -> TransformStamped:
        for f in (target, source):
            if not (f in self._edges or any(e.parent == f for e in self._edges.values())):
                known = ", ".join(self.frames()) or "none"
                raise UnknownFrameError(f'frame "{f}" does not exist (known frames: {known})')
        up_s, up_t = self._chain(source), self._chain(target)
        common = set(up_t)
        k = next((i for i, f in enumerate(up_s) if f in common), None)
        if k is None:
            raise ConnectivityError(
                f'could not find a connection between "{target}" and "{source}": they are in two '
                f'unconnected trees (roots "{up_t[-1]}" and "{up_s[-1]}")')
        anc = up_s[k]
        path_s, path_t = up_s[:k], up_t[:up_t.index(anc)]  # children whose edges are traversed
        dynamic = [self._edges[c].stamps[-1] for c in path_s + path_t if not self._edges[c].static]
        if time == 0.0:
            time = min(dynamic) if dynamic else 0.0
        t_anc_src = Transform()
        for c in reversed(path_s):
            t_anc_src = t_anc_src.compose(self._edge_at(c, time))
        t_anc_tgt = Transform()
        for c in reversed(path_t):
            t_anc_tgt = t_anc_tgt.compose(self._edge_at(c, time))
        tr = t_anc_tgt.inverse().compose(t_anc_src)
        return TransformStamped(Header(time, target), source, tr)

    def lookup(self, target: str, source: str, time: float = 0.0, timeout: float = 0.0) -> TransformStamped:
        """Transform taking ``source`` coordinates into ``target`` at ``time`` (0 = latest common).

        With ``timeout`` > 0, waits (in the clock's seconds) for the transform to become available and
        raises the last ``TFError`` if it does not."""
        target, source = strip_frame(target), strip_frame(source)
        if not target or not source:
            raise UnknownFrameError(f"empty frame id (target {target!r}, source {source!r})")
        deadline = self.clock.now() + timeout
        with self._cv:
            while True:
                try:
                    if target == source:
                        return TransformStamped(Header(time, target), source, Transform())
                    return self._lookup_now(target, source, float(time))
                except TFError as err:
                    remaining = deadline - self.clock.now()
                    if remaining <= 0:
                        if timeout > 0:
                            raise type(err)(f"{err} (after waiting {timeout:.2f} s)") from None
                        raise
                    # A simulated clock may run faster than the wall: re-check it often.
                    self._cv.wait(min(remaining, 0.05) if getattr(self.clock, "simulated", False)
                                  else remaining)

    def can_transform(self, target: str, source: str, time: float = 0.0, timeout: float = 0.0) -> bool:
        try:
            self.lookup(target, source, time, timeout)
            return True
        except TFError:
            return False

    def lookup_pose2d(self, target: str, source: str, time: float = 0.0, timeout: float = 0.0) -> Pose2D:
        """The pose of ``source``'s origin in ``target`` projected on the plane (x, y, yaw)."""
        return self.lookup(target, source, time, timeout).transform.to_pose2d()

    def transform_points(self, target: str, source: str, points: np.ndarray, time: float = 0.0,
                         timeout: float = 0.0) -> np.ndarray:
        """(N, 3) points in ``source`` -> ``target``; (N, 2) points are taken at z = 0 and return (x, y)."""
        tr = self.lookup(target, source, time, timeout).transform
        p = np.asarray(points)
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise ValueError(f"points must be (N, 2) or (N, 3), got shape {p.shape}")
        if p.shape[1] == 2:
            p3 = np.zeros((len(p), 3), dtype=p.dtype if p.dtype.kind == "f" else float)
            p3[:, :2] = p
            return tr.apply(p3)[:, :2]
        return tr.apply(p)

