"""Fixtures for TF tests: two-session loopback bus configs (multicast off, explicit free port)."""

from __future__ import annotations

import pytest

from common.zenoh_config import BusConfig
from tests.support import free_port  # noqa: F401


@pytest.fixture
def loopback(robot_name):
    """(listen_config, connect_config): a node with the first listens on a free loopback port, nodes with
    the second connect to it. Multicast scouting is off so tests never meet other sessions."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    return (BusConfig(robot=robot_name, multicast=False, listen=(endpoint,)),
            BusConfig(robot=robot_name, multicast=False, connect=(endpoint,)))

