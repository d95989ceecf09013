"""Liveliness keys are built and read back in one place (common.live_keys)."""

from common.live_keys import LiveKey, live_key


def test_a_publication_key_round_trips_with_a_topic_holding_slashes():
    k = live_key("r1", "pub", "move_base", "/move_base/status/")
    assert k == "zenavlive/r1/pub/move_base/move_base/status"
    assert LiveKey.parse(k) == LiveKey("r1", "pub", "move_base", "move_base/status")
    assert LiveKey.parse(k).node == "move_base"


def test_node_keys_patterns_and_foreign_keys():
    assert LiveKey.parse("zenavlive/r1/node/sim") == ("r1", "node", "sim", "")
    assert live_key("*", "node", "*") == "zenavlive/*/node/*"
    assert live_key("r1", "**", "") == "zenavlive/r1/**"
    assert LiveKey.parse("zenav/r1/scan/x") is None  # a data key, not a liveliness one
    assert LiveKey.parse("zenavlive/r1/node") is None  # too short
