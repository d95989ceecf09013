"""Commands that must arrive: sent as a bus service call and retried until the node that acts on them
answers, or reported failed after a deadline — never silently lost.

A topic put (ROS's ``move_base_simple/goal``) is fire-and-forget: when the route to the subscriber is
not (yet) there — a link that just healed, a peer still starting — the message is gone and nobody
knows. A service call is answered by the node that acted on the request, so the sender knows; if the
answer does not come the call is repeated (the receiver treats a repeat with the same id as the same
command), until ``deadline``.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from common.bus import Node, ServiceError, ServiceTimeout, ServiceUnavailable

__all__ = ["DeliveryFailed", "cancel_goal", "last_seen", "send_acknowledged", "send_goal"]


class DeliveryFailed(ServiceError):
    """No answer from the receiving node within the deadline."""


def send_acknowledged(node: Node, service: str, request: Any, response_type: type | None = None,
                      deadline: float = 10.0, attempt_timeout: float = 1.0, what: str = "",
                      seen: Callable[[], str] | None = None, cancelled=lambda: False) -> Any:
    """Call ``service`` until it answers (its response is returned) or ``deadline`` s have passed
    (``DeliveryFailed``, with ``seen()``'s text: e.g. when the receiver's status was last heard).
    A ``ServiceError`` raised by the handler — an answer saying no — is passed on at once."""
    t0 = time.monotonic()
    attempts, last = 0, "no node serves it"
    while True:
        left = deadline - (time.monotonic() - t0)
        if left <= 0 or cancelled():
            break
        attempts += 1
        try:
            return node.call(service, request, response_type, timeout=min(attempt_timeout, max(left, 0.05)))
        except ServiceUnavailable:
            last = "no node serving it was reachable"
            time.sleep(min(0.2, max(0.0, deadline - (time.monotonic() - t0))))  # no route yet: ask again soon
        except ServiceTimeout:
            last = "it was reachable but did not answer"
    who = what or f"'{service}' of robot '{node.robot}'"
    extra = f"; {seen()}" if seen is not None else ""
    raise DeliveryFailed(f"{who} did not answer within {deadline:.0f} s ({attempts} attempts, {last}{extra})")


def last_seen(sub, what: str) -> Callable[[], str]:
    """For DeliveryFailed's text: when ``sub`` (a Subscription) last received something."""
    def text() -> str:
        if not sub.received:
            return f"{what} never seen"
        return f"{what} last seen {time.monotonic() - sub.last_receive_time:.1f} s ago"
    return text


def send_goal(node: Node, goal, deadline: float = 10.0, seen: Callable[[], str] | None = None,
              cancelled=lambda: False):
    """A MoveBaseGoal to move_base, acknowledged: returns move_base's MoveBaseStatus for it (ACTIVE, or
    REJECTED with the reason). Safe to repeat: move_base knows the goal by its id."""
    from common.messages import MoveBaseStatus

    return send_acknowledged(node, "move_base/send_goal", goal, MoveBaseStatus, deadline,
                             what=f"move_base of robot '{node.robot}'", seen=seen, cancelled=cancelled)


def cancel_goal(node: Node, goal_id: str = "", deadline: float = 5.0, seen: Callable[[], str] | None = None):
    """Cancel ``goal_id`` (any goal when empty), acknowledged: returns the goal's MoveBaseStatus."""
    from common.messages import Header, MoveBaseStatus, Text

    return send_acknowledged(node, "move_base/cancel_goal", Text(Header(), goal_id), MoveBaseStatus, deadline,
                             what=f"move_base of robot '{node.robot}'", seen=seen)
