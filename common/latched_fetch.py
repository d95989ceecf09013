"""Keys of the zenav bus and the fetch of a latched topic's last message: every latched publisher of a key
answers a query with it (``common.bus_topics.Publisher``), asked again on a doubling wait when a new
publisher gave no answer."""

from __future__ import annotations

import logging
import threading
from typing import Callable

import zenoh

from common.query_routes import ask_redeclare
from common.zenoh_threads import track_retry

__all__ = ["topic_key", "fetch_latched", "LATCHED_RETRY_S", "NOTHING_YET"]

log = logging.getLogger("zenav.bus")


def topic_key(robot: str, topic: str) -> str:
    topic = topic.strip("/")
    if not topic or "*" in topic or "$" in topic:
        raise ValueError(f"bad topic name {topic!r}")
    return f"zenav/{robot}/{topic}"


# waits before asking again when a new publisher gave no reply: quickly at first, then every 16 s for
# about two minutes (a query right after a reconnect can find no route for a while: Zenoh issue #2767)
LATCHED_RETRY_S = (0.5, 1.0, 2.0, 4.0, 8.0) + (16.0,) * 7
# a latched publisher asked before its first message answers this (and its name) instead of nothing: the
# route works, the message will come live, and no one keeps asking (move_base's result, before any goal
# has ended, was asked for every 16 s with a warning that its queryable had no route)
NOTHING_YET = "latched: nothing published yet by "


def fetch_latched(session: zenoh.Session, key: str, on_ok: Callable[[zenoh.Sample], None],
                  retry: bool = False, closed: Callable[[], bool] = lambda: False, attempt: int = 0,
                  expect: str = "") -> None:
    """Ask every latched publisher of ``key`` for its last message (``on_ok`` per answer).

    ``retry`` (the query follows a publisher's liveliness token): when no one answered, ask again after
    ``LATCHED_RETRY_S``. The token can arrive before the publisher's queryable is routable (it may travel
    another way through the peers), and that publisher announces itself only once: without a second
    query its latched map would never come (seen on a loaded machine). ``expect``: the name of the
    publisher whose token started this; only its answer counts (another publisher of the same key, e.g. a
    second static TF publisher, answering at once must not end the retries before this one answers). A
    reply without the publisher's name (not a zenav publisher) counts: it cannot be told apart."""
    answered = [False]

    def on_reply(reply: zenoh.Reply) -> None:
        if reply.ok is not None:
            att = reply.ok.attachment
            if not expect or att is None or att.to_bytes().decode(errors="replace") == expect:
                answered[0] = True
            on_ok(reply.ok)
        elif reply.err is not None:  # reached, and nothing to give yet: as good as an answer
            why = reply.err.payload.to_string()
            if why.startswith(NOTHING_YET) and (not expect or why[len(NOTHING_YET):] == expect):
                answered[0] = True

    def on_done() -> None:
        if retry and not answered[0] and attempt < len(LATCHED_RETRY_S) and not closed():
            if attempt >= 1:  # the publisher's token is there, its queryable unreachable: ask it to declare again
                ask_redeclare(session, key, "latched fetch")
            t = threading.Timer(LATCHED_RETRY_S[attempt], fetch_latched,
                                (session, key, on_ok, True, closed, attempt + 1, expect))
            t.daemon = True
            track_retry(t, session)  # cancelled with its session (common/zenoh_threads.py)
            t.start()

    if closed():  # a retry due after its subscriber closed
        return
    try:
        session.get(key, zenoh.handlers.Callback(on_reply, on_done), target=zenoh.QueryTarget.ALL,
                    consolidation=zenoh.ConsolidationMode.NONE)
    except zenoh.ZError as e:  # the session is closing
        log.debug("latched query on %s failed: %s", key, e)
