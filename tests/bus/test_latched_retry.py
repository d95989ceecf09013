"""A latched publisher whose liveliness token arrives before its queryable can answer (the two may
travel different ways through the peers; a CI run on a loaded machine lost a map this way): the
subscriber and `zenav record` ask again, so the latched message still comes."""

from __future__ import annotations

import threading

import numpy as np
import zenoh

from common.codec import encode
from common.latched_fetch import LATCHED_RETRY_S, fetch_latched
from common.messages import Header, OccupancyGrid
from tests.support import wait_until

GRID = OccupancyGrid(Header(7.0, "map"), 0.05, data=np.zeros((2, 3), np.int8))


def _token_then_queryable(node, key: str, topic: str, ready: threading.Event):
    """The token of a latched publisher of ``topic`` now; its queryable only once ``ready`` is set."""
    node._declare_token("pub", topic)
    node._declare_token("latched", topic)
    held = []

    def late() -> None:
        ready.wait(30)
        held.append(node.session.declare_queryable(key, lambda q: q.reply(key, encode(GRID)), complete=False))

    threading.Thread(target=late, daemon=True).start()
    return held


def test_a_subscriber_gets_the_latched_message_of_a_publisher_whose_queryable_came_late(node_pair):
    sub_node = node_pair("costmap")
    sub = sub_node.subscribe("map", OccupancyGrid)
    pub_node = node_pair("map_server")
    ready = threading.Event()
    _token_then_queryable(pub_node, pub_node.key("map"), "map", ready)
    # the subscriber has seen the token and asked (no answer: nothing to ask yet) before the queryable
    wait_until(lambda: any("map_server" in k for k in _live_pubs(sub_node)), 30, "the publisher's token")
    ready.set()
    got = sub.wait_first(timeout=5 + sum(LATCHED_RETRY_S))
    assert got is not None and got.header.stamp == 7.0


def test_without_a_retry_one_query_gets_nothing_and_the_retry_gets_the_message(node_pair):
    asker, answerer = node_pair("asker"), node_pair("answerer")
    key = answerer.key("map")
    once, again = [], []
    fetch_latched(asker.session, key, once.append, retry=False)
    fetch_latched(asker.session, key, again.append, retry=True)
    answerer.session.declare_queryable(key, lambda q: q.reply(key, encode(GRID)), complete=False)
    wait_until(lambda: again, 5 + sum(LATCHED_RETRY_S), "the retried query's answer")
    assert once == []  # asked before the queryable existed, once: nothing, ever
    assert len(again) == 1 and isinstance(again[0], zenoh.Sample)


def _live_pubs(node) -> list[str]:
    from common.bus import list_live

    return list_live(node.session, node.robot, kind="pub")


def test_a_second_static_tf_publisher_is_asked_until_it_answers_itself(node_pair):
    """Two static TF publishers: the first answers every query at once; the second's token comes before
    its queryable. A listener must not take the first one's answer as the second's: it gets both frames."""
    from common.geometry import Transform
    from common.messages import TFMessage, TransformStamped
    from common.tf import TFListener

    listener_node = node_pair("listener")
    first = node_pair("base_to_laser")
    first.publisher("tf_static", latched=True).publish(
        TFMessage((TransformStamped(Header(0.0, "base_link"), "laser", Transform()),)))
    tf = TFListener(listener_node)
    wait_until(lambda: tf.buffer.can_transform("base_link", "laser"), 30, "the first static transform")
    second = node_pair("base_to_camera")
    key = second.key("tf_static")
    camera = encode(TFMessage((TransformStamped(Header(0.0, "base_link"), "camera", Transform()),)))
    second._declare_token("pub", "tf_static")
    second._declare_token("latched", "tf_static")  # as a latched publisher declares it
    wait_until(lambda: any("base_to_camera" in k for k in _live_pubs(listener_node)), 30, "the second's token")
    # its token is seen (and asked for, answered by the first publisher only) before its queryable exists
    second.session.declare_queryable(key, lambda q: q.reply(key, camera, attachment=second.name.encode()),
                                     complete=False)
    wait_until(lambda: tf.buffer.can_transform("base_link", "camera"), 5 + sum(LATCHED_RETRY_S),
               "the second static transform")


def test_a_latched_publisher_with_nothing_yet_is_asked_once_and_its_first_message_comes_live(node_pair):
    """move_base's result before any goal has ended: reachable, nothing to give. The subscriber's fetch
    counts that as an answer: no retries asking the publisher to declare its queryable again (each
    logged a warning, every 16 s for two minutes); the first message then comes as a live put."""
    pub_node = node_pair("move_base")
    pub = pub_node.publisher("move_base/result", latched=True)
    sub_node = node_pair("goal_sender")
    sub = sub_node.subscribe("move_base/result", OccupancyGrid)
    wait_until(lambda: any("move_base" in k for k in _live_pubs(sub_node)), 30, "the publisher's token")
    threading.Event().wait(sum(LATCHED_RETRY_S[:3]) + 1.0)  # an absence: the retries' first three waits
    assert pub_node.queryables.redeclared == 0
    pub.publish(GRID)
    got = sub.wait_first(timeout=30)
    assert got is not None and got.header.stamp == 7.0
