"""The zenav bus: a small Node API over a real Zenoh session.

Keys are ``zenav/<robot>/<topic>`` (topics named as in ROS: ``scan``, ``odom``, ``tf``, ``cmd_vel``…),
services ``zenav/<robot>/srv/<name>``; every node holds a liveliness token
``zenavlive/<robot>/node/<name>`` and one per publication ``zenavlive/<robot>/pub/<name>/<topic>``,
so ``zenav nodes`` / ``zenav topic list`` see who is there without any master.
See docs/CONVENTIONS.md for the API in one page.
"""

from __future__ import annotations

__all__ = ["Node", "Publisher", "Subscription", "ServiceError", "ServiceTimeout", "ServiceUnavailable",
           "list_live", "topic_key"]

import contextlib
import logging
import os
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

import zenoh

from common.bus_topics import Publisher, Subscription
from common.clock import SimClock, Timer, WallClock
from common.codec import DecodeError, decode, encode
from common.latched_fetch import topic_key
from common.live_keys import PREFIX as LIVE_PREFIX
from common.live_keys import live_key
from common.messages import Clock, Header, NodeStats, TopicStats
from common.query_routes import Queryables, ask_redeclare
from common.route_watch import RouteWatch
from common.tcp_linger import open_session
from common.zenoh_config import BusConfig
from common.zenoh_threads import JOIN_TIMEOUT_S, cancel_retries, join_all

log = logging.getLogger("zenav.bus")


class ServiceError(RuntimeError):
    """The service ran and reported a failure (its text is the message)."""


class ServiceTimeout(ServiceError):
    """No reply within the timeout."""


class ServiceUnavailable(ServiceError):
    """No node serves that name."""


class Node:
    """A named participant on the bus. Owns a Zenoh session unless one is passed in."""

    def __init__(self, name: str, robot: str | None = None, config: BusConfig | None = None,
                 session: zenoh.Session | None = None, use_sim_time: bool | str | None = None) -> None:
        if not name or "/" in name or "*" in name:
            raise ValueError(f"bad node name {name!r}")
        self.config = config or BusConfig.from_env()
        self.robot = robot or self.config.robot
        self.name = name
        self._owns_session = session is None
        self.session = session if session is not None else open_session(self.config.to_zenoh())
        self._entities: list[Any] = []
        self.routes = RouteWatch(self.session, self.robot, name)  # silent streams declared again
        self._timers: list[Timer] = []
        self._pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix=f"srv:{name}")
        self.queryables = Queryables(self.session, self.robot, name)  # declared again when a querier asks
        self._entities.append(self.queryables)
        self._closed = False
        if use_sim_time is None:
            env = os.environ.get("ZENAV_USE_SIM_TIME", "0")
            use_sim_time = "auto" if env == "auto" else env in ("1", "true", "yes")
        sim = SimClock() if use_sim_time is True else None
        self.clock: WallClock | SimClock = sim if sim is not None else WallClock()
        self.stats_sources: list[Any] = []  # objects with stats() -> TopicStats rows (subscriptions, TF)
        if sim is not None:
            self.subscribe("clock", Clock, callback=lambda m: sim.update(m.clock), inline=True)
        elif use_sim_time == "auto":
            self.subscribe("clock", Clock, callback=self._auto_clock, inline=True)
        self.service(f"node_stats/{name}", lambda _req: self.stats(), token=False)
        self._node_token = self._declare_token("node")
        self.log = logging.getLogger(f"zenav.{name}")

    def _auto_clock(self, m: Clock) -> None:
        """use_sim_time="auto": wall time until the robot's simulator publishes ``clock``, its time from the
        first message on (a command started before, or beside, a simulated robot: ``zenav goal``, ``zenav
        explore``). A wall-clock node refuses messages stamped more than 300 s ahead of it, and a simulator at
        --speed 2 gets that far ahead of the wall in five minutes. Timers made before keep the wall clock."""
        clock = self.clock
        if isinstance(clock, SimClock):
            clock.update(m.clock)
            return
        sim = SimClock()
        sim.update(m.clock)
        self.clock = sim

    # -- helpers -------------------------------------------------------------------------------
    def _declare_token(self, kind: str, topic: str = ""):
        """This node's liveliness token of ``kind`` (common.live_keys)."""
        tok = self.session.liveliness().declare_token(live_key(self.robot, kind, self.name, topic))
        self._entities.append(tok)
        return tok

    def key(self, topic: str) -> str:
        return topic_key(self.robot, topic)

    # -- pub / sub -----------------------------------------------------------------------------
    def publisher(self, topic: str, latched: bool = False, reliable: bool = False,
                  background: bool = False) -> Publisher:
        """``reliable``: block the caller while Zenoh's send queue toward a peer is full (True) or drop
        the message then (False, the default, latched topics included, as rmw_zenoh does). A blocked put
        does not stall its caller alone: every process that routes it (the agent, a router) pushes it
        toward the congested peer holding that link's send lock for up to Zenoh's ``wait_before_close``
        (5 s), and the lease cannot close the link meanwhile. One robot-side state toward a master behind a
        just-cut link froze every route of the robot agent for the whole cut: the collision monitor's
        zero commands and the simulator's ground truth stopped reaching nodes on the robot itself
        (tests/reliability/test_cut_link_routes.py). A latched message lost to a full queue still reaches
        its subscribers by the latched query whenever the publisher's token is seen again (a re-formed
        link), and states are published again at their rate. ``reliable=True`` is for what is worth that
        risk: a whole map, whose fragments a drop would lose under any brief congestion.
        ``background``: a state published from a control loop — put by a sender thread, the newest
        superseding unsent ones, so the loop never waits on the network (common/bus_sender.py)."""
        pub = Publisher(self, topic, latched, reliable, background)
        self._entities.append(pub)
        return pub

    def subscribe(self, topic: str, msg_type: type | None = None, callback: Callable | None = None,
                  mode: str = "latest", queue_size: int = 100, inline: bool = False) -> Subscription:
        sub = Subscription(self, topic, msg_type, callback, mode, queue_size, inline)
        self._entities.append(sub)
        self.routes.add(sub)
        self.stats_sources.append(sub)
        return sub

    def own(self, obj: Any) -> Any:
        """Close ``obj`` (its ``close()``) with this node, before the session, and join its ``threads()``
        after: for helpers with threads of their own that use the node (common.tf.StaticTFBroadcaster)."""
        self._entities.append(obj)
        return obj

    def stats(self) -> NodeStats:
        """Counters of every subscription (and TF listener) of this node; also served as
        ``node_stats/<name>`` (``zenav nodes --stats``)."""
        rows = [TopicStats(*row) for src in list(self.stats_sources) for row in src.stats()]
        return NodeStats(Header(self.clock.now(), ""), self.name, os.getpid(), tuple(rows))

    # -- services ------------------------------------------------------------------------------
    def service(self, name: str, handler: Callable[[Any], Any], request_type: type | None = None,
                token: bool = True):
        key = f"zenav/{self.robot}/srv/{name.strip('/')}"

        def run(query: zenoh.Query) -> None:
            try:
                payload = query.payload
                req = decode(payload.to_bytes() if payload is not None else b"", request_type)
            except DecodeError as e:
                query.reply_err(f"bad request: {e}".encode())
                return
            try:
                resp = handler(req)
                query.reply(key, encode(resp))
            except Exception as e:
                query.reply_err(f"{type(e).__name__}: {e}".encode())
            finally:
                query.drop()

        def submit(query: zenoh.Query) -> None:
            self._pool.submit(run, query)

        q = self.queryables.declare(key, submit, complete=True)
        if token:  # node_stats/<node> has none: every node serves it
            self._declare_token("srv", name)
        return q

    def call(self, name: str, request: Any, response_type: type | None = None, timeout: float = 2.0) -> Any:
        key = f"zenav/{self.robot}/srv/{name.strip('/')}"
        t0 = time.monotonic()
        replies = self.session.get(key, payload=encode(request), timeout=timeout,
                                   target=zenoh.QueryTarget.BEST_MATCHING)
        for reply in replies:
            if reply.ok is not None:
                try:
                    return decode(reply.ok.payload.to_bytes(), response_type)
                except DecodeError as e:
                    raise ServiceError(f"service '{name}' sent a bad reply: {e}") from e
            err = reply.err.payload.to_string() if reply.err is not None else "unknown error"
            if err.lower().startswith("timeout"):
                raise ServiceTimeout(f"service '{name}' did not answer within {timeout:.1f} s")
            raise ServiceError(f"service '{name}' failed: {err}")
        if time.monotonic() - t0 < timeout * 0.9:  # no queryable reached: its owner, if any, declares it again
            ask_redeclare(self.session, key, self.name)
            raise ServiceUnavailable(f"no node serves '{name}' on robot '{self.robot}'")
        raise ServiceTimeout(f"service '{name}' did not answer within {timeout:.1f} s")

    # -- time ----------------------------------------------------------------------------------
    def timer(self, period: float, fn: Callable[[], None], on_data: bool = False) -> Timer:
        """``fn`` every ``period`` s of the node's clock; ``on_data``: when kicked (see ``Timer``)."""
        def on_error(e: Exception) -> None:
            self.log.error("timer callback raised: %s\n%s", e, traceback.format_exc())

        t = Timer(self.clock, period, fn, name=f"timer:{self.name}", on_error=on_error, on_data=on_data)
        self._timers.append(t)
        return t

    # -- lifecycle -----------------------------------------------------------------------------
    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.routes.close()
        for t in self._timers:
            t.cancel()
        if isinstance(self.clock, SimClock):
            self.clock.close()
        for t in self._timers:
            t.join(1.0)
        for e in reversed(self._entities):
            with contextlib.suppress(Exception):  # best effort on shutdown
                e.close() if hasattr(e, "close") else e.undeclare()
        self._pool.shutdown(wait=False, cancel_futures=True)
        # the session's latched-query retries, when the session is this node's: a shared one's belong to its
        # other users too (this node's own stop by themselves, their subscriptions closed)
        retries = cancel_retries(self.session) if self._owns_session else []
        if self._owns_session:
            with contextlib.suppress(zenoh.ZError):  # "close operation timed out" over a dead link
                self.session.close()
        # no thread of this node may still be inside Zenoh when the interpreter ends: it would abort the
        # process (common/zenoh_threads.py); a call on the closed session returns at once
        threads = [self.routes.thread, *(t.thread for t in self._timers), *retries,
                   *(t for e in self._entities if hasattr(e, "threads") for t in e.threads())]
        left = join_all(threads)
        if left:
            self.log.warning("threads still running %.0f s after close: %s", JOIN_TIMEOUT_S, ", ".join(left))

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def list_live(session: zenoh.Session, robot: str = "*", kind: str = "node", timeout: float = 1.0) -> list[str]:
    """Liveliness keys currently declared (e.g. kind 'node' -> ['robot1/node/sim', ...])."""
    out = []
    for reply in session.liveliness().get(live_key(robot, kind, "**"), timeout=timeout):
        if reply.ok is not None:
            out.append(str(reply.ok.key_expr).removeprefix(f"{LIVE_PREFIX}/"))
    return sorted(set(out))


def close_quietly(*objs) -> None:
    """Undeclare / close each of ``objs`` (Zenoh handles, sessions, nodes; None skipped), ignoring errors:
    for the way out, where a dead link must not stop the rest from closing."""
    for o in objs:
        if o is None:
            continue
        with contextlib.suppress(Exception):  # best effort on the way out
            o.undeclare() if hasattr(o, "undeclare") else o.close()
