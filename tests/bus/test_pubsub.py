"""Publish/subscribe semantics between two sessions: keep-latest vs queue, latched topics, callbacks."""

from __future__ import annotations

import threading

import numpy as np
from bushelp import wait_for

from common.bus import list_live
from common.messages import Header, OccupancyGrid, Text


def _matched(pub) -> None:
    wait_for(lambda: pub._pub.matching_status.matching, timeout=30, what="publisher matched")


def test_keep_latest_holds_only_the_newest_message(node_pair):
    a, b = node_pair("pub"), node_pair("sub")
    sub = b.subscribe("chatter", Text)  # default mode: latest
    pub = a.publisher("chatter", reliable=True)  # the subscriber's semantics, not DROP under load
    _matched(pub)
    for i in range(50):
        pub.publish(Text(Header(float(i)), str(i)))
    wait_for(lambda: sub.received == 50, timeout=30, what="50 messages")
    assert sub.latest().data == "49"
    assert sub.get(timeout=1.0).data == "49"  # only one is kept...
    assert sub.dropped == 49  # ...and each overwritten one is counted


def test_queue_mode_delivers_every_message_in_order(node_pair):
    a, b = node_pair("pub"), node_pair("sub")
    sub = b.subscribe("cmd", Text, mode="queue", queue_size=100)
    small = b.subscribe("cmd", Text, mode="queue", queue_size=10)
    pub = a.publisher("cmd", reliable=True)
    _matched(pub)
    for i in range(50):
        pub.publish(Text(data=str(i)))
    assert [sub.get(timeout=20).data for _ in range(50)] == [str(i) for i in range(50)]
    assert sub.dropped == 0
    wait_for(lambda: small.received == 50, timeout=30, what="small queue to see all")
    assert [small.get(timeout=1).data for _ in range(10)] == [str(i) for i in range(40, 50)]
    assert small.dropped == 40


def test_queue_mode_callback_sees_every_message_in_order(node_pair):
    a, b = node_pair("pub"), node_pair("sub")
    got, done = [], threading.Event()

    def cb(m: Text) -> None:
        got.append(int(m.data))
        if len(got) == 200:
            done.set()

    b.subscribe("cmd_vel", Text, callback=cb, mode="queue", queue_size=500)
    pub = a.publisher("cmd_vel", reliable=True)
    _matched(pub)
    for i in range(200):
        pub.publish(Text(data=str(i)))
    assert done.wait(30)
    assert got == list(range(200))


def test_latched_topic_is_delivered_to_a_late_subscriber(node_pair, robot_name):
    a = node_pair("map_server")
    latched = a.publisher("map", latched=True)
    plain = a.publisher("chatter")
    grid = OccupancyGrid(Header(3.0, "map"), 0.05, data=(np.arange(12) % 3 - 1).astype(np.int8).reshape(3, 4))
    latched.publish(grid)
    plain.publish(Text(data="said before anyone listened"))
    b = node_pair("late")  # joins after both messages were published
    missed = b.subscribe("chatter", Text)
    got = b.subscribe("map", OccupancyGrid).wait_first(timeout=30)
    assert got.data.tolist() == grid.data.tolist()
    assert got.header == grid.header
    # The plain topic's (earlier) query has been answered with nothing: it is not replayed.
    assert missed.received == 0
    assert missed.latest() is None
    # A second late subscriber in the same node gets the latched map too.
    assert b.subscribe("map", OccupancyGrid).wait_first(timeout=30).header.stamp == 3.0


def test_publisher_and_subscriber_tokens_are_visible(node_pair, robot_name):
    a, b = node_pair("talker"), node_pair("listener")
    a.publisher("scan")
    wait_for(
        lambda: f"{robot_name}/pub/talker/scan" in list_live(b.session, robot_name, kind="pub"),
        timeout=30,
        what="pub token",
    )
    assert {f"{robot_name}/node/talker", f"{robot_name}/node/listener"} <= set(
        list_live(b.session, robot_name)
    )
