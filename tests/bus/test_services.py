"""Services over queryables: round trip, timeout, no server, handler error, bad request."""

from __future__ import annotations

import threading
import time

import pytest
from bushelp import wait_for

from common.bus import ServiceError, ServiceTimeout, ServiceUnavailable, list_live
from common.messages import Header, Scalar, Text


@pytest.fixture
def server_client(node_pair, robot_name):
    server, client = node_pair("server"), node_pair("client")
    release = threading.Event()

    def add_one(req: Scalar) -> Scalar:
        return Scalar(req.header, req.value + 1.0)

    def slow(req):
        release.wait(30)
        return req

    def broken(req):
        raise ValueError("the map is not loaded")

    server.service("add_one", add_one, request_type=Scalar)
    server.service("slow", slow)
    server.service("broken", broken)
    # Ready when the client can see the server's service tokens (liveliness crossed the link).
    wait_for(
        lambda: len(list_live(client.session, robot_name, kind="srv")) == 3, timeout=30, what="service tokens"
    )
    yield server, client
    release.set()


def test_service_round_trip_returns_the_handlers_reply(server_client):
    _, client = server_client
    for v in (0.0, -2.5, 1e9):
        reply = client.call("add_one", Scalar(Header(1.0, "x"), v), response_type=Scalar, timeout=10.0)
        assert reply == Scalar(Header(1.0, "x"), v + 1.0)


def test_service_slower_than_timeout_raises_service_timeout(server_client):
    _, client = server_client
    t0 = time.monotonic()
    with pytest.raises(ServiceTimeout):
        client.call("slow", Text(data="zzz"), timeout=0.5)
    assert time.monotonic() - t0 < 10.0


def test_service_nobody_serves_raises_service_unavailable_quickly(server_client):
    _, client = server_client
    t0 = time.monotonic()
    with pytest.raises(ServiceUnavailable, match="no_such_service"):
        client.call("no_such_service", Text(data="?"), timeout=10.0)
    assert time.monotonic() - t0 < 5.0


def test_service_handler_exception_becomes_service_error_with_its_text(server_client):
    _, client = server_client
    with pytest.raises(ServiceError, match="ValueError: the map is not loaded") as ei:
        client.call("broken", Text(data="go"), timeout=10.0)
    assert not isinstance(ei.value, (ServiceTimeout, ServiceUnavailable))


def test_service_request_of_wrong_type_is_rejected_as_bad_request(server_client):
    _, client = server_client
    with pytest.raises(ServiceError, match="bad request") as ei:
        client.call("add_one", Text(data="not a scalar"), timeout=10.0)
    assert not isinstance(ei.value, (ServiceTimeout, ServiceUnavailable))
    # The service still works afterwards.
    assert client.call("add_one", Scalar(value=1.0), response_type=Scalar, timeout=10.0).value == 2.0


def test_service_reply_of_unexpected_type_raises_service_error(server_client):
    _, client = server_client
    with pytest.raises(ServiceError, match="bad reply"):
        client.call("add_one", Scalar(value=1.0), response_type=Text, timeout=10.0)
