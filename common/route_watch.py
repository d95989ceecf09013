"""Streams are watched, not trusted: a subscription that its live publisher stopped reaching is declared
again.

After a link is cut and healed, Zenoh re-forms the links between the sessions, but a subscriber's
declaration may not reach a publisher again (Zenoh's tracker has bugs of that shape: interests and write
filters not re-propagated after a reconnect). Data then never comes, though the publisher is alive and
announced. Seen once in the link-fault tests on a loaded machine: after a 3 s partition, fake_localization
received nothing from the simulator for 10 minutes while move_base, in the same namespace, did.

A *stream* is a subscription that has received messages at a regular period. When it falls silent for
``SILENT_PERIODS`` periods (at least ``SILENT_MIN_S``) while the publisher of its last message still holds
its liveliness token — so that publisher is alive and its announcements reach us — the subscription is
declared again (undeclared, then declared: every peer recomputes its routes toward it). While the silence
lasts, the wait doubles after each attempt, up to ``MAX_WAIT_S``: a publisher that merely stopped
publishing costs one declaration a minute. A publisher whose token is not seen may be gone: the watch
waits for it (its new token or its data) — but only ``UNSEEN_WAIT_S``. The token is looked up with a
liveliness query, and queries travel the routes that a reconnect may have left broken. In a loaded CI run
fake_localization, stopped (SIGSTOP) beyond the lease and continued, published nothing more for 270 s (its
last map→odom kept the stamp of the stop) while the simulator ran on: its inputs' routes were lost and not
repaired, and the one look that declares nothing is "publisher gone". So a stream unseen for longer is
declared again too, on the same doubling wait. When data flows again within ``REPAIR_WINDOW_S`` of a
declaration, the node logs the repair as a warning (a route was lost; which topic, from whom, for how
long) and counts it (``Node.routes.repairs``); data that comes back later was a pause of the publisher
(move_base's cmd_vel between goals), not a repair.

A subscription that has received *nothing* has no stream to watch, yet its route can be lost from the start:
in a loaded CI run move_base planned for 10 s on "no global costmap received yet" while the costmap node
published at 10 Hz and the test's own subscriber received it. So a subscription still unfed ``UNFED_WAIT_S``
after it was added is declared again if some publisher announces its topic (a liveliness token), on the same
doubling wait; its first message within ``REPAIR_WINDOW_S`` of such a declaration is logged and counted as a
repair. An announced publisher that simply has not published yet (a goal tool) costs a declaration at 5, 15
and 35 s, and no more (``UNFED_MAX_ATTEMPTS``): each is a gap in which its message could be missed, from the
undeclaration until the new declaration reaches the publisher's session (a message's trip between the peers).
Declared once a minute for good, move_base's ``move_base/cancel`` lost a test's cancel, published minutes
after the stack started, in a loaded CI run (likely so: nothing came, and the cancel was the topic's first
message). A subscription still unfed after three declarations is a command topic waiting for its first
command, not a lost stream. Commands that must arrive do not rely on a topic put (common.delivery).

Time alone cannot tell a repair from a coincidence: move_base's first result, or its first cmd_vel once a goal
came, may arrive just after a declaration made for nothing. So every zenav publisher numbers its puts (Zenoh's
source info: the publisher's entity id and a sequence number from 1). Data that comes back with no number
skipped since the last message (or a subscription's first message numbered 1) lost nothing: the publisher
had paused, and no repair is counted. A repair is counted only when numbers were skipped, or when the
publisher does not number its messages (then the time window alone decides, as before).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Any, Protocol

from common.live_keys import live_key

log = logging.getLogger("zenav.bus")

STREAM_MIN_MSGS = 5  # messages before a subscription's period is trusted
SILENT_PERIODS = 20.0  # silence, in periods of the stream, before its route is doubted
SILENT_MIN_S = 2.0
MAX_WAIT_S = 60.0
UNSEEN_WAIT_S = 10.0  # silence after which a publisher whose token is not seen is declared for anyway
CHECK_EVERY_S = 0.5
UNFED_WAIT_S = 5.0  # a subscription that has received nothing this long while its topic is announced is doubted
UNFED_MAX_ATTEMPTS = 3  # declarations of a still unfed subscription; then it is left alone (see above)
REPAIR_WINDOW_S = 1.0  # data back this soon after a declaration: the declaration repaired the route (else
# the publisher had only paused, e.g. move_base's cmd_vel between goals)


class Watched(Protocol):
    """What the watch needs of a subscription (common.bus_topics.Subscription, common.tf.TFListener)."""

    topic: str
    sources: dict[bytes, Stream]  # publisher name -> its stream so far (see count_source)

    @property
    def closed(self) -> bool: ...

    def redeclare(self) -> None: ...


def sequence_number(sample: Any) -> tuple[str, int] | None:
    """(publisher entity id, sequence number) of a Zenoh sample, None when its publisher does not number them."""
    si = sample.source_info
    return (str(si.source_id), int(si.source_sn)) if si is not None else None


@dataclass(slots=True)
class Stream:
    """One publisher's messages on one subscription, as the watch sees them (times: monotonic seconds)."""

    n: int  # messages so far
    last: float  # the last message's arrival
    period: float  # smoothed gap between messages, pauses left out
    resumed: float  # the first message after the last pause (the first message of all, until a pause)
    sn: tuple[str, int] | None  # (entity id, sequence number) of the last message (None: not numbered)
    skipped: int  # messages numbered just before ``resumed`` that never came (-1: unknown)


def count_source(sources: dict[bytes, Stream], who: bytes, now: float, sn: tuple[str, int] | None = None) -> None:
    """Count one message of publisher ``who`` in ``sources`` (see ``Watched``), ``sn`` its ``sequence_number``.
    A gap over 10 periods is a pause, not the stream's rate: it is not averaged in, and the message that ends
    it is remembered, with the messages skipped just before it (from the sequence numbers, when the same
    publisher entity numbered both; for the first message, those numbered before it)."""
    src = sources.get(who)
    if src is None:
        sources[who] = Stream(1, now, 0.0, now, sn, sn[1] - 1 if sn is not None else -1)
        return
    gap = now - src.last
    if src.n == 1:
        src.period = gap
    elif gap > 10.0 * src.period:
        src.resumed = now
        last = src.sn
        src.skipped = sn[1] - last[1] - 1 if sn is not None and last is not None and sn[0] == last[0] \
            and sn[1] > last[1] else -1
    else:
        src.period = 0.9 * src.period + 0.1 * gap
    src.n += 1
    src.last = now
    src.sn = sn


@dataclass
class _Doubt:
    silent_from: float  # the publisher's last message before the silence (monotonic)
    declared_at: float = float("-inf")  # the last declaration (monotonic)
    attempts: int = 0  # declarations made during this silence
    next_at: float = 0.0  # monotonic time of the next look
    decision: str = ""  # the last look's outcome (tests, debugging)


class RouteWatch:
    """One thread per node looking at its subscriptions every ``CHECK_EVERY_S``, per publisher."""

    def __init__(self, session: Any, robot: str, node_name: str) -> None:  # a zenoh.Session
        self.session, self.robot, self.node_name = session, robot, node_name
        self.subs: list[Watched] = []
        self.repairs = 0
        self.losses = 0  # silences that lost messages without a declaration bringing them back (see look)
        self.doubts: dict[tuple[str, str], _Doubt] = {}  # (topic, publisher) -> a silent stream
        self.unfed: dict[int, _Doubt] = {}  # id(subscription) -> its doubt, while it has been fed nothing
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True, name=f"routes:{node_name}")
        self.thread.start()

    def add(self, sub: Watched) -> None:
        self.subs.append(sub)
        now = time.monotonic()
        self.unfed[id(sub)] = _Doubt(silent_from=now, next_at=now + UNFED_WAIT_S)

    def close(self) -> None:
        self._stop.set()

    def _run(self) -> None:
        import zenoh

        while not self._stop.wait(CHECK_EVERY_S):
            for sub in list(self.subs):
                try:
                    if id(sub) in self.unfed:
                        if sub.closed:
                            del self.unfed[id(sub)]
                        else:
                            self.look_unfed(sub, time.monotonic())
                    if not sub.closed:
                        for who, st in list(sub.sources.items()):
                            self.look(sub, who.decode(errors="replace"), st.n, st.last, st.period, st.resumed,
                                      time.monotonic(), st.skipped)
                except zenoh.ZError:  # the session is closing
                    return

    def look(self, sub: Watched, publisher: str, n: int, last: float, period: float, resumed: float,
             now: float, skipped: int = -1) -> None:
        """One stream (``publisher`` on ``sub.topic``): ``n`` messages so far, the last at ``last``, the first
        after its last pause at ``resumed``, ``skipped`` messages numbered between that one and the one before
        (-1: unknown)."""
        if n < STREAM_MIN_MSGS:
            return
        key = (sub.topic, publisher)
        doubt = self.doubts.get(key)
        if doubt is not None and last > doubt.silent_from:  # data again
            del self.doubts[key]
            first = resumed if resumed > doubt.silent_from else last
            if resumed <= doubt.silent_from:
                skipped = -1  # the pause remembered is older than this silence
            if doubt.attempts and skipped != 0 and 0.0 <= first - doubt.declared_at <= REPAIR_WINDOW_S:
                self.repairs += 1
                log.warning("[%s] route repaired: '%s' from %s, silent for %.1f s, flows again %.2f s after the "
                            "subscription was declared again (attempt %d)%s", self.node_name, sub.topic, publisher,
                            first - doubt.silent_from, first - doubt.declared_at, doubt.attempts, _lost(skipped))
            elif skipped > 0:  # not after a declaration of ours, yet messages were lost: say so all the same
                self.losses += 1
                log.warning("[%s] '%s' from %s was silent for %.1f s and %d message(s) numbered in between never "
                            "came (%d declaration(s) of the subscription meanwhile)", self.node_name, sub.topic,
                            publisher, first - doubt.silent_from, skipped, doubt.attempts)
            return
        silence = now - last
        limit = max(SILENT_MIN_S, SILENT_PERIODS * period)
        if doubt is None:
            if silence < limit:
                return
            doubt = self.doubts[key] = _Doubt(silent_from=last)
        if now < doubt.next_at:
            return
        if silence < UNSEEN_WAIT_S and not self._alive(publisher, sub.topic):
            doubt.decision, doubt.next_at = "publisher gone", now + limit
            return
        self._declare_again(sub, doubt, now, limit)
        log.debug("[%s] '%s' from %s silent for %.1f s, the publisher alive: subscription declared again",
                  self.node_name, sub.topic, publisher, silence)

    @staticmethod
    def _declare_again(sub: Watched, doubt: _Doubt, now: float, wait: float) -> None:
        """Declare ``sub`` again; the next look after ``wait`` doubled per attempt (at most MAX_WAIT_S)."""
        sub.redeclare()
        doubt.declared_at = time.monotonic()
        doubt.attempts += 1
        doubt.decision = f"declared again ({doubt.attempts})"
        doubt.next_at = now + min(wait * 2 ** doubt.attempts, MAX_WAIT_S)

    def look_unfed(self, sub: Watched, now: float) -> None:
        """A subscription that has received nothing since it was added (see the module's text)."""
        doubt = self.unfed[id(sub)]
        if sub.sources:  # fed at last
            del self.unfed[id(sub)]
            first, skipped = min((st.resumed, st.skipped) for st in list(sub.sources.values()))
            # skipped == 0: the publisher's first message (move_base's first result), nothing was lost
            if doubt.attempts and skipped != 0 and 0.0 <= first - doubt.declared_at <= REPAIR_WINDOW_S:
                self.repairs += 1
                log.warning("[%s] route repaired: '%s' received nothing for %.1f s though announced, then its "
                            "first message %.2f s after the subscription was declared again (attempt %d)%s",
                            self.node_name, sub.topic, first - doubt.silent_from, first - doubt.declared_at,
                            doubt.attempts, _lost(skipped))
            return
        if now < doubt.next_at:
            return
        if doubt.attempts >= UNFED_MAX_ATTEMPTS:
            doubt.decision, doubt.next_at = "left alone: announced, never fed (a command topic)", float("inf")
            return
        if not self._alive("*", sub.topic):
            doubt.decision, doubt.next_at = "not announced", now + UNFED_WAIT_S
            return
        self._declare_again(sub, doubt, now, UNFED_WAIT_S)
        log.debug("[%s] '%s' fed nothing for %.1f s though announced: subscription declared again",
                  self.node_name, sub.topic, now - doubt.silent_from)

    def _alive(self, publisher: str, topic: str) -> bool:
        """Whether the publisher's liveliness token for ``topic`` is known to this session now."""
        key = live_key(self.robot, "pub", publisher, topic)
        return any(r.ok is not None for r in self.session.liveliness().get(key, timeout=1.0))


def _lost(skipped: int) -> str:
    return f", {skipped} message(s) numbered in between never came" if skipped > 0 else ""
