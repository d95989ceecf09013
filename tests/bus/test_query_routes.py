"""Queries are watched too (common.query_routes), on two real peers over loopback.

The fault: a queryable whose declaration no longer reaches the querier's session, while puts still flow
(bench/reconnect.py saw it after healed partitions). It is made here by undeclaring the Zenoh queryable
behind the node's back. A service call then finds no node; the caller asks, over a put, that the owner
declare it again, and the next attempt is answered. The same for a latched publisher's queryable."""

from __future__ import annotations

import numpy as np
from bushelp import wait_for

from common import query_routes
from common.delivery import send_acknowledged
from common.messages import Header, OccupancyGrid, Text


def test_a_service_whose_queryable_declaration_is_lost_answers_after_the_caller_asks(node_pair):
    server, caller = node_pair("move_base"), node_pair("goal_sender")
    q = server.service("echo", lambda req: req, Text)
    assert send_acknowledged(caller, "echo", Text(data="one"), Text, deadline=30.0).data == "one"
    q.handle.undeclare()  # the fault: the caller's session no longer knows this queryable
    wait_for(lambda: caller.session.get(q.key, timeout=1.0) and not list(caller.session.get(q.key, timeout=1.0)),
             30, "the query reaching no queryable")
    got = send_acknowledged(caller, "echo", Text(data="two"), Text, deadline=30.0)
    assert got.data == "two"
    assert server.queryables.redeclared >= 1


def test_a_latched_map_whose_queryable_is_lost_still_reaches_a_new_subscriber(node_pair):
    server, late = node_pair("map_server"), node_pair("recorder")
    pub = server.publisher("map", latched=True)
    pub.publish(OccupancyGrid(Header(7.0, "map"), 0.05, data=np.zeros((2, 3), np.int8)))
    pub._queryable.handle.undeclare()  # the fault
    sub = late.subscribe("map", OccupancyGrid)
    got = sub.wait_first(timeout=60.0)
    assert got is not None and got.header.stamp == 7.0
    assert server.queryables.redeclared >= 1


def test_asking_is_rate_limited_per_key_and_a_bad_request_is_counted(node_pair):
    server, caller = node_pair("server"), node_pair("caller")
    key = f"zenav/{caller.robot}/srv/nobody_{id(caller)}"
    assert query_routes.ask_redeclare(caller.session, key, "caller")
    assert not query_routes.ask_redeclare(caller.session, key, "caller")  # within MIN_INTERVAL_S
    caller.session.put(query_routes.redeclare_key(caller.robot), b"\x00garbage")
    wait_for(lambda: server.queryables.malformed >= 1, 30, "the malformed request counted")
