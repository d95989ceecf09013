"""Streams are watched (common.route_watch), on two real peers over loopback.

The fault a lost route leaves behind is a subscriber whose declaration no longer reaches the publisher's
session: data stops while the publisher is alive and announced. It is made here by undeclaring the
subscription's Zenoh subscriber behind the Node's back — from the publisher's side exactly what a
declaration lost in a reconnect looks like. The watch must notice the silence, see the publisher's token,
declare the subscription again, and say so once data flows. A publisher that is gone is not a route to
repair: nothing is declared for it — for ``UNSEEN_WAIT_S``, since the token's lookup can be lost with the
route."""

from __future__ import annotations

import threading

from bushelp import wait_for

from common import route_watch
from common.geometry import Transform
from common.messages import Header, Text, TransformStamped
from common.tf import TFBroadcaster, TFListener


def _stream(stop: threading.Event, send, period: float = 0.02) -> threading.Thread:
    def run():
        while not stop.wait(period):
            send()
    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def _chatter(node_pair) -> tuple:
    """listener <- talker on ``chatter`` at 50 Hz, flowing (20 messages in): (listener, its subscription,
    the event that stops the talker)."""
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("chatter", Text, callback=lambda m: None)
    pub = talker.publisher("chatter")
    stop = threading.Event()
    _stream(stop, lambda: pub.publish(Text(data="hello")))
    try:
        wait_for(lambda: sub.received >= 20, 30, "the stream")
    except AssertionError:
        stop.set()
        raise
    return listener, sub, stop


def test_a_stream_whose_subscriber_declaration_is_lost_is_declared_again_and_flows(node_pair):
    listener, sub, stop = _chatter(node_pair)
    try:
        sub._sub.undeclare()  # the fault: the publisher's session no longer routes to this subscriber
        lost_at = sub.received
        wait_for(lambda: sub.received > lost_at + 20, 30, "the stream after its route was lost")
        wait_for(lambda: listener.routes.repairs == 1, 10, "the repair counted")
        assert not listener.routes.doubts
    finally:
        stop.set()


def test_the_tf_stream_of_one_publisher_is_repaired_too(node_pair):
    listener, talker = node_pair("listener"), node_pair("odom_pub")
    tf = TFListener(listener)
    out = TFBroadcaster(talker)
    stop = threading.Event()
    _stream(stop, lambda: out.send([TransformStamped(Header(talker.clock.now(), "odom"), "base_link", Transform())]))
    try:
        wait_for(lambda: tf.received >= 20, 30, "the tf stream")
        tf._stream.undeclare()
        lost_at = tf.received
        wait_for(lambda: tf.received > lost_at + 20, 30, "tf after its route was lost")
        wait_for(lambda: listener.routes.repairs == 1, 10, "the repair counted")
    finally:
        stop.set()


def _paused_chatter(node_pair) -> tuple:
    """listener <- talker on ``chatter``: 20 messages at 50 Hz, then the talker pauses. (listener, its
    subscription, the talker's publisher)."""
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("chatter", Text)
    pub = talker.publisher("chatter")
    stop = threading.Event()
    sender = _stream(stop, lambda: pub.publish(Text(data="hello")))
    try:
        wait_for(lambda: sub.received >= 20, 30, "the stream")
    finally:
        stop.set()  # the pause
        sender.join()
    return listener, sub, pub


def _declare_once(monkeypatch) -> None:
    """For tests that publish one message after the watch declared a subscription again: a message put before
    that declaration reaches the publisher's session is lost (a loaded CI run lost one so). The watch declares
    once only, and ``_round_trip`` shows when that declaration got there."""
    declare = route_watch.RouteWatch._declare_again

    def once(sub, doubt, now, wait):
        declare(sub, doubt, now, wait)
        doubt.next_at = float("inf")

    monkeypatch.setattr(route_watch.RouteWatch, "_declare_again", staticmethod(once))


def _round_trip(listener, publisher: str, topic: str) -> None:
    """Wait for a liveliness query to ``publisher`` to be answered: sent after the listener's last declaration
    over the same link, it shows the declaration got there."""
    wait_for(lambda: listener.routes._alive(publisher, topic), 30, "a round trip to the publisher")


def test_a_publisher_that_is_gone_is_waited_for_not_repaired(node_pair):
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("chatter", Text)
    pub = talker.publisher("chatter")
    stop = threading.Event()
    sender = _stream(stop, lambda: pub.publish(Text(data="hello")))
    wait_for(lambda: sub.received >= 20, 30, "the stream")
    stop.set()
    sender.join()
    talker.close()  # its liveliness tokens go with it
    wait_for(lambda: (d := listener.routes.doubts.get(("chatter", "talker"))) and d.decision == "publisher gone",
             30, "the watch to find the publisher gone")
    assert listener.routes.doubts[("chatter", "talker")].attempts == 0
    assert listener.routes.repairs == 0


def test_a_lost_stream_whose_token_lookup_is_lost_too_is_declared_again_after_the_unseen_wait(node_pair,
                                                                                              monkeypatch):
    """The route and the liveliness lookup both lost (the lookup answering "no token", as a query with no
    route does): after UNSEEN_WAIT_S the subscription is declared again anyway, and data flows."""
    monkeypatch.setattr(route_watch, "UNSEEN_WAIT_S", 3.0)
    listener, sub, stop = _chatter(node_pair)
    try:
        monkeypatch.setattr(listener.routes, "_alive", lambda publisher, topic: False)
        sub._sub.undeclare()
        lost_at = sub.received
        wait_for(lambda: (d := listener.routes.doubts.get(("chatter", "talker"))) and d.decision == "publisher gone",
                 30, "the watch to find no token first")
        wait_for(lambda: sub.received > lost_at + 20, 30, "the stream after the unseen wait")
        wait_for(lambda: listener.routes.repairs == 1, 10, "the repair counted")
    finally:
        stop.set()


def test_a_subscription_whose_route_is_lost_before_its_first_message_is_declared_again(node_pair, monkeypatch):
    """Nothing received yet, so no stream to watch: the subscription is declared again once its topic is
    announced (the publisher's token) and nothing came for UNFED_WAIT_S; the first message is then a repair."""
    monkeypatch.setattr(route_watch, "UNFED_WAIT_S", 1.0)
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("chatter", Text)
    sub._sub.undeclare()  # the fault, before any message
    pub = talker.publisher("chatter")
    stop = threading.Event()
    _stream(stop, lambda: pub.publish(Text(data="hello")))
    try:
        wait_for(lambda: sub.received >= 20, 30, "the stream whose route was lost before its first message")
        wait_for(lambda: listener.routes.repairs == 1, 10, "the repair counted")
        assert not listener.routes.unfed
    finally:
        stop.set()


def test_a_subscription_whose_topic_nobody_announces_is_not_declared_again(node_pair, monkeypatch):
    monkeypatch.setattr(route_watch, "UNFED_WAIT_S", 0.5)
    listener = node_pair("listener")
    sub = listener.subscribe("nobody_publishes_this", Text)
    wait_for(lambda: listener.routes.unfed[id(sub)].decision == "not announced", 30, "the watch to look")
    assert listener.routes.unfed[id(sub)].attempts == 0


def test_every_message_carries_its_publishers_sequence_number(node_pair):
    """Zenoh's source info on each put: the subscription sees the numbers run from 1 without a gap."""
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("chatter", Text)
    pub = talker.publisher("chatter")
    wait_for(lambda: pub.matching, 30, "the route to the listener")
    for _ in range(3):
        pub.publish(Text(data="hello"))
    wait_for(lambda: sub.received == 3, 30, "three messages")
    st = sub.sources[b"talker"]
    n, (entity, sn), skipped = st.n, st.sn, st.skipped
    assert (n, sn, skipped) == (3, 3, 0)
    assert entity == str(pub._id)


def test_a_first_message_that_comes_just_after_a_declaration_is_no_repair(node_pair, monkeypatch):
    """move_base's first result, 36 s after the subscription and just after a declaration made for nothing:
    numbered 1, it lost nothing, so no repair is counted, however wide the time window."""
    monkeypatch.setattr(route_watch, "UNFED_WAIT_S", 0.5)
    monkeypatch.setattr(route_watch, "REPAIR_WINDOW_S", 1000.0)  # time alone would call it a repair
    _declare_once(monkeypatch)
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("result", Text)
    pub = talker.publisher("result")  # announced, silent
    wait_for(lambda: listener.routes.unfed[id(sub)].attempts >= 1, 30, "a declaration while nothing came")
    _round_trip(listener, "talker", "result")
    pub.publish(Text(data="goal reached"))
    wait_for(lambda: sub.received == 1, 30, "the first message")
    wait_for(lambda: not listener.routes.unfed, 10, "the watch to see it fed")
    assert listener.routes.repairs == 0


def test_a_stream_that_pauses_and_resumes_without_a_gap_is_no_repair(node_pair, monkeypatch):
    """cmd_vel between two goals: silent long enough to be declared again, then the next number comes."""
    monkeypatch.setattr(route_watch, "SILENT_MIN_S", 0.5)
    monkeypatch.setattr(route_watch, "REPAIR_WINDOW_S", 1000.0)
    _declare_once(monkeypatch)
    listener, sub, pub = _paused_chatter(node_pair)
    wait_for(lambda: (d := listener.routes.doubts.get(("chatter", "talker"))) is not None and d.attempts >= 1,
             30, "a declaration during the pause")
    _round_trip(listener, "talker", "chatter")
    before = sub.received
    pub.publish(Text(data="again"))
    wait_for(lambda: sub.received > before, 30, "the stream again")
    wait_for(lambda: ("chatter", "talker") not in listener.routes.doubts, 10, "the watch to see it flow")
    assert listener.routes.repairs == 0


def test_a_silence_that_lost_messages_is_reported_even_without_a_repair(node_pair, monkeypatch):
    """Messages that never came, with no declaration of ours bringing the rest back (the route healed by
    itself, or a congested link dropped them): the numbers skipped say so, and it is logged and counted.

    The watch must declare nothing here: a message published while the subscription is declared again is
    lost until the new declaration reaches the talker's session (a CI run lost "again" that way, and the
    loss was never reported because nothing came). So the talker's token is not seen, and the watch waits."""
    monkeypatch.setattr(route_watch, "SILENT_MIN_S", 0.5)
    monkeypatch.setattr(route_watch, "UNSEEN_WAIT_S", 1000.0)
    monkeypatch.setattr(route_watch.RouteWatch, "_alive", lambda self, publisher, topic: False)
    listener, _sub, pub = _paused_chatter(node_pair)
    wait_for(lambda: (d := listener.routes.doubts.get(("chatter", "talker"))) and d.decision == "publisher gone",
             30, "the silence noticed")
    assert listener.routes.doubts[("chatter", "talker")].attempts == 0
    pub.sn += 5  # five messages put where the listener never got them
    pub.publish(Text(data="again"))
    wait_for(lambda: listener.routes.losses == 1, 30, "the loss reported")
    assert listener.routes.repairs == 0 and listener.routes.doubts == {}


def test_an_announced_subscription_never_fed_is_declared_again_three_times_only(node_pair, monkeypatch):
    """move_base/cancel with a cancel tool announced and silent: each declaration is a gap in which the one
    cancel could be lost, so after UNFED_MAX_ATTEMPTS the watch leaves it alone; the cancel then arrives."""
    monkeypatch.setattr(route_watch, "UNFED_WAIT_S", 0.2)
    listener, talker = node_pair("listener"), node_pair("talker")
    sub = listener.subscribe("cancel", Text)
    pub = talker.publisher("cancel")  # announced, silent
    wait_for(lambda: listener.routes.unfed[id(sub)].decision.startswith("left alone"), 30, "the watch to stop")
    assert listener.routes.unfed[id(sub)].attempts == route_watch.UNFED_MAX_ATTEMPTS
    _round_trip(listener, "talker", "cancel")  # the last declaration got there
    pub.publish(Text(data="cancel"))
    wait_for(lambda: sub.received == 1, 30, "the cancel")
    wait_for(lambda: not listener.routes.unfed, 10, "the watch to see it fed")
