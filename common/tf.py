"""TF on the bus: listener, broadcasters and the static_transform_publisher argument parser.

Topics (ROS names): ``tf`` (TFMessage, streamed) and ``tf_static`` (TFMessage, latched; each static
broadcaster republishes all its transforms in one message, like tf2_ros). The buffer itself is pure:
see ``common.tf_buffer``. Usage::

    tf = TFListener(node)
    ts = tf.buffer.lookup("map", "base_link", time=0.0, timeout=0.5)   # TransformStamped
    TFBroadcaster(node).send(TransformStamped(Header(stamp, "odom"), "base_link", pose))
    StaticTFBroadcaster(node).send(parse_static_args("0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"))
"""

from __future__ import annotations

import ast
import contextlib
import logging
import math
import operator
import threading
import time
from typing import Any, Callable

from common.config import strip_frame
from common.geometry import Quaternion, Transform, Vector3
from common.live_keys import LiveKey, live_key
from common.messages import Header, TFMessage, TransformStamped
from common.msg_check import problem
from common.route_watch import Stream, count_source, sequence_number
from common.tf_buffer import (
    ConnectivityError,
    EdgeInfo,
    ExtrapolationError,
    TFBuffer,
    TFError,
    UnknownFrameError,
)
from common.zenoh_threads import join_all

__all__ = [
    "TFBuffer", "TFError", "UnknownFrameError", "ConnectivityError", "ExtrapolationError", "EdgeInfo",
    "TFListener", "TFBroadcaster", "StaticTFBroadcaster", "parse_static_args", "eval_number",
]

log = logging.getLogger("zenav.tf")

# -- static_transform_publisher arguments ------------------------------------------------------

_BINOPS: dict[type, Callable[[float, float], float]] = {ast.Add: operator.add, ast.Sub: operator.sub,
                                                       ast.Mult: operator.mul, ast.Div: operator.truediv}
_UNOPS: dict[type, Callable[[float], float]] = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_NAMES = {"pi": math.pi, "PI": math.pi}


def eval_number(text: str) -> float:
    """A number or a simple expression of numbers and ``pi`` with + - * / and parentheses
    (``pi/2``, ``-0.5*pi``, ``1e-3``). Parsed with ``ast`` and evaluated node by node — never eval()."""

    def ev(n: ast.AST) -> float:
        if isinstance(n, ast.Expression):
            return ev(n.body)
        if isinstance(n, ast.Constant) and isinstance(n.value, (int, float)) and not isinstance(n.value, bool):
            return float(n.value)
        if isinstance(n, ast.Name) and n.id in _NAMES:
            return _NAMES[n.id]
        if isinstance(n, ast.BinOp) and type(n.op) in _BINOPS:
            return _BINOPS[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp) and type(n.op) in _UNOPS:
            return _UNOPS[type(n.op)](ev(n.operand))
        raise ValueError(f"not a number or simple expression: {text!r}")

    if len(text) > 100:
        raise ValueError(f"expression too long: {text[:20]!r}...")
    try:
        value = ev(ast.parse(text.strip(), mode="eval"))
    except (SyntaxError, ZeroDivisionError) as e:
        raise ValueError(f"not a number or simple expression: {text!r} ({e})") from None
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {text!r}")
    return value


def _is_number(text: str) -> bool:
    try:
        eval_number(text)
        return True
    except ValueError:
        return False


def parse_static_args(args: str | list[str], stamp: float = 0.0) -> tuple[TransformStamped, float | None]:
    """Parse ROS ``static_transform_publisher`` arguments; returns (transform, period_s or None).

    ``x y z yaw pitch roll frame child [period_ms]`` or ``x y z qx qy qz qw frame child [period_ms]``
    (yaw about z, pitch about y, roll about x, fixed axes; numbers may be expressions with ``pi``).
    The transform maps ``child`` coordinates into ``frame``. Raises ValueError naming the problem."""
    tok = args.split() if isinstance(args, str) else [str(a) for a in args]
    n = len(tok)
    # 9 tokens: tf2 quaternion form without period, or tf1 euler form with period (7th is a frame).
    nums = 7 if n == 10 or (n == 9 and _is_number(tok[6])) else 6
    if n not in (8, 9, 10) or (n == 8 and _is_number(tok[6])):
        raise ValueError(f"static transform needs 'x y z yaw pitch roll frame child [period_ms]' or "
                         f"'x y z qx qy qz qw frame child [period_ms]', got {n} arguments: {' '.join(tok)!r}")
    names = ("x", "y", "z", "qx", "qy", "qz", "qw") if nums == 7 else ("x", "y", "z", "yaw", "pitch", "roll")
    v = []
    for name, t in zip(names, tok):
        try:
            v.append(eval_number(t))
        except ValueError as e:
            raise ValueError(f"argument {name}: {e}") from None
    frame, child = strip_frame(tok[nums]), strip_frame(tok[nums + 1])
    if not frame or not child or frame == child:
        raise ValueError(f"static transform needs two different frame ids, got {frame!r} and {child!r}")
    if nums == 7:
        q = Quaternion(*v[3:7])
        try:
            q = q.normalized()
        except ValueError:
            raise ValueError("quaternion (qx qy qz qw) has zero length") from None
    else:
        yaw, pitch, roll = v[3:6]
        q = Quaternion.from_euler(roll, pitch, yaw)
    period = None
    if n > nums + 2:
        period_ms = eval_number(tok[-1])
        if period_ms <= 0:
            raise ValueError(f"period_ms must be > 0, got {tok[-1]!r}")
        period = period_ms / 1000.0
    return TransformStamped(Header(stamp, frame), child, Transform(Vector3(*v[:3]), q)), period


# -- bus adapters --------------------------------------------------------------------------------

def _as_list(transforms: TransformStamped | list | tuple) -> list[TransformStamped]:
    items = [transforms] if isinstance(transforms, TransformStamped) else list(transforms)
    out = []
    for ts in items:
        if not isinstance(ts, TransformStamped):
            raise TypeError(f"expected TransformStamped, got {type(ts).__name__}")
        out.append(TransformStamped(Header(ts.header.stamp, strip_frame(ts.header.frame_id)),
                                    strip_frame(ts.child_frame_id), ts.transform))
    return out


class TFBroadcaster:
    """Publishes transforms on ``tf``."""

    def __init__(self, node) -> None:
        self._pub = node.publisher("tf")

    def send(self, transforms: TransformStamped | list[TransformStamped]) -> None:
        self._pub.publish(TFMessage(tuple(_as_list(transforms))))

    def close(self) -> None:
        self._pub.close()


# A static broadcaster sends its whole set again this often. Latched messages go best effort (common/bus.py):
# a late listener gets the set by the latched query, but a *change* sent after it joined (the simulator adds
# camera_link -> camera_depth_frame once it has seen the mount) can be dropped on a congested link, and the
# listener then kept the old set for good (a CI run: the collision monitor blind for 6 minutes, "two
# unconnected trees"). ROS 1's static_transform_publisher sent every period_ms for the same reason.
STATIC_REPUBLISH_S = 2.0


class StaticTFBroadcaster:
    """Publishes static transforms on latched ``tf_static``; every send republishes all transforms this
    broadcaster has sent (keyed by child frame), so a late listener gets them all in one message; the set
    goes out again every ``republish_s`` (None: never) once something was sent."""

    def __init__(self, node, republish_s: float | None = STATIC_REPUBLISH_S) -> None:
        self._pub = node.publisher("tf_static", latched=True)
        self._all: dict[str, TransformStamped] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if republish_s is not None:
            self._thread = threading.Thread(target=self._republish, args=(republish_s,), daemon=True,
                                            name="tf_static:republish")
            self._thread.start()
        node.own(self)  # closed, and its thread joined, with the node

    def threads(self) -> list[threading.Thread]:
        return [self._thread] if self._thread is not None else []

    def send(self, transforms: TransformStamped | list[TransformStamped]) -> None:
        with self._lock:
            for ts in _as_list(transforms):
                self._all[ts.child_frame_id] = ts
            self._pub.publish(TFMessage(tuple(self._all.values())))

    def _republish(self, period: float) -> None:
        while not self._stop.wait(period):
            with self._lock:
                if not self._all:
                    continue
                try:
                    self._pub.publish(TFMessage(tuple(self._all.values())))
                except Exception:  # noqa: BLE001 - the node's session closed under us: nothing left to do
                    return

    def close(self) -> None:
        self._stop.set()
        with self._lock:
            self._pub.close()
        join_all([self._thread])  # it may be inside a put (common/zenoh_threads.py)


def _frames_problem(msg: TFMessage) -> str | None:
    """A transform the buffer would refuse (checked first so a message is applied whole or not at all)."""
    for ts in msg.transforms:
        parent, child = strip_frame(ts.header.frame_id), strip_frame(ts.child_frame_id)
        if not parent or not child or parent == child:
            return f"bad frames {ts.header.frame_id!r} -> {ts.child_frame_id!r}"
    return None


class _NodeClock:
    """The node's clock as it is at each call: a node on use_sim_time="auto" switches to the simulator's."""

    def __init__(self, node) -> None:
        self._node = node

    def __getattr__(self, name: str):
        return getattr(self._node.clock, name)


class TFListener:
    """Fills ``self.buffer`` from ``tf`` and ``tf_static`` of the node's robot.

    Each sample's publisher (the node name the bus puts in the attachment) is recorded per edge. Latched
    static transforms are requested from *every* static publisher, again whenever a new one appears
    (liveliness), so a listener started before or after them gets all of them.

    ``static_only``: ``tf_static`` alone, for a node that needs only mounts (the simulator): the ``tf``
    stream is a few hundred messages a second with a simulator at 2x, each decoded by every listener."""

    def __init__(self, node, cache_time: float = 10.0, buffer: TFBuffer | None = None,
                 static_only: bool = False) -> None:
        import zenoh  # the adapter needs per-sample attachments and QueryTarget.ALL

        from common.codec import DecodeError, decode

        self._zenoh, self._decode, self._decode_error = zenoh, decode, DecodeError
        self.buffer = buffer if buffer is not None else TFBuffer(cache_time, clock=_NodeClock(node))
        self._node, self._session = node, node.session
        self.malformed = 0  # payloads that are not a TFMessage
        self.invalid = 0  # TFMessages refused whole: NaN, zero quaternion, far-future stamp, bad frames
        self.received = 0
        self.topic = "tf"  # the stream common.route_watch looks at (tf_static is latched, not a stream)
        self.sources: dict[bytes, Stream] = {}
        self._closed = False
        node.stats_sources.append(self)
        self._key_tf, self._key_static = node.key("tf"), node.key("tf_static")
        self._handles: list[Any] = [
            self._session.declare_subscriber(self._key_static, lambda s: self._on_sample(s, True)),
            self._session.liveliness().declare_subscriber(
                live_key(node.robot, "latched", "*", "tf_static"), self._on_static_publisher, history=True),
        ]
        self._stream: Any = None  # the tf stream's subscriber, watched for lost routes (common.route_watch)
        if not static_only:
            self._stream = self._session.declare_subscriber(self._key_tf, lambda s: self._on_sample(s, False))
            node.routes.add(self)

    @property
    def closed(self) -> bool:
        return self._closed

    def redeclare(self) -> None:
        """Declare the tf subscriber again (common.route_watch), the old one first."""
        if self._closed or self._stream is None:
            return
        with contextlib.suppress(self._zenoh.ZError):
            self._stream.undeclare()
        self._stream = self._session.declare_subscriber(self._key_tf, lambda s: self._on_sample(s, False))

    def _on_static_publisher(self, sample) -> None:
        """A static publisher's token: ask until *that* publisher answers (common.latched_fetch.fetch_latched;
        another one answering at once does not count)."""
        k = LiveKey.parse(sample.key_expr)
        if sample.kind == self._zenoh.SampleKind.PUT and k is not None:
            from common.latched_fetch import fetch_latched

            fetch_latched(self._session, self._key_static,
                          lambda s: self._ingest(s.payload.to_bytes(), s.attachment, True), retry=True,
                          closed=lambda: self._closed, expect=k.node)

    def _on_sample(self, sample, static: bool) -> None:
        self._ingest(sample.payload.to_bytes(), sample.attachment, static, sequence_number(sample))

    def _ingest(self, data: bytes, attachment, static: bool, sn: tuple[str, int] | None = None) -> None:
        try:
            msg = self._decode(data, TFMessage)
        except self._decode_error as e:
            self.malformed += 1
            self._dropped("malformed", self.malformed, e)
            return
        why = problem(msg, self._node.clock.now()) or _frames_problem(msg)
        if why:
            self.invalid += 1
            self._dropped("invalid", self.invalid, why)
            return
        who_b = attachment.to_bytes() if attachment is not None else b""
        who = who_b.decode(errors="replace")
        try:
            for ts in msg.transforms:
                self.buffer.set_transform(ts, authority=who, static=static)
        except (ValueError, TypeError) as e:  # checked above; kept so a new buffer rule cannot kill the thread
            self.invalid += 1
            self._dropped("invalid", self.invalid, e)
            return
        self.received += 1
        if not static and who_b:
            count_source(self.sources, who_b, time.monotonic(), sn)

    def _dropped(self, kind: str, n: int, why) -> None:
        if n == 1 or n % 100 == 0:
            log.warning("[%s] dropped %s TF message (#%d): %s", self._node.name, kind, n, why)

    def stats(self) -> tuple[tuple[str, str, int, int, int, int, int], ...]:
        """Rows of the node's stats (see Subscription.stats): tf and tf_static together."""
        topics = "tf+tf_static" if self._stream is not None else "tf_static"
        return ((topics, "TFMessage", self.received, self.malformed, self.invalid, 0, 0),)

    def close(self) -> None:
        self._closed = True
        for h in [*self._handles, self._stream]:
            if h is None:
                continue
            with contextlib.suppress(Exception):  # the session may already be closed
                h.undeclare()
        self._handles = []
