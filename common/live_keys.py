"""Liveliness keys: who is on the bus, in one place.

Every node declares ``zenavlive/<robot>/node/<name>``, per publication
``zenavlive/<robot>/pub/<name>/<topic...>``, per latched publication also ``.../latched/<name>/<topic...>``
and per service ``.../srv/<name>/<service...>`` (common.bus). Tools (``zenav nodes``, ``topic``, ``doctor``,
``fleet``) and the bus itself (latched fetches, the route watch) read them back; they build and parse them
here, so the layout is written once.
"""

from __future__ import annotations

from typing import NamedTuple

PREFIX = "zenavlive"


class LiveKey(NamedTuple):
    robot: str
    kind: str  # "node", "pub", "latched" or "srv"
    node: str
    topic: str = ""  # the published topic ("pub" keys), may hold "/"

    @classmethod
    def parse(cls, key) -> LiveKey | None:
        """``zenavlive/<robot>/<kind>/<node>[/<topic...>]`` (a str or a Zenoh key expression), else None."""
        parts = str(key).split("/")
        if len(parts) < 4 or parts[0] != PREFIX:
            return None
        return cls(parts[1], parts[2], parts[3], "/".join(parts[4:]))

    def __str__(self) -> str:
        return "/".join(p for p in (PREFIX, self.robot, self.kind, self.node, self.topic.strip("/")) if p)


def live_key(robot: str, kind: str, node: str = "*", topic: str = "") -> str:
    """A key or a pattern: ``live_key("r1", "pub", "*", "map")`` -> ``zenavlive/r1/pub/*/map``."""
    return str(LiveKey(robot, kind, node, topic))
