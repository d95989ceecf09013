"""A subscriber survives hostile payloads: each is counted as malformed, the next valid one decodes."""

from __future__ import annotations

import random
import struct

import msgpack
import numpy as np
import pytest
import zenoh
from bushelp import wait_for

from common.codec import DecodeError, decode, encode
from common.messages import Header, LaserScan, Text


def _valid_scan(seq: int) -> LaserScan:
    return LaserScan(
        Header(float(seq), f"laser#{seq}"),
        -1.0,
        1.0,
        0.01,
        0.0,
        0.1,
        0.1,
        10.0,
        np.linspace(0.5, 5.0, 201, dtype=np.float32),
        np.ones(201, np.float32),
    )


def _array_ext(dtype: str, shape: tuple[int, ...], body: bytes) -> msgpack.ExtType:
    head = (
        struct.pack("<BB", len(dtype), len(shape)) + dtype.encode() + struct.pack(f"<{len(shape)}Q", *shape)
    )
    return msgpack.ExtType(1, head + body)


def hostile_payloads(n: int, seed: int) -> list[bytes]:
    """n payloads, none of which is a valid LaserScan: 6 kinds in turn."""
    rng = random.Random(seed)
    good = encode(_valid_scan(7))
    body = msgpack.unpackb(good, raw=False, ext_hook=lambda c, d: msgpack.ExtType(c, d))[3]
    out = []
    for i in range(n):
        kind = i % 6
        if kind == 0:  # random bytes
            p = rng.randbytes(rng.randint(0, 3000))
        elif kind == 1:  # truncated valid payload
            p = good[: rng.randint(0, len(good) - 1)]
        elif kind == 2:  # valid msgpack of the wrong shape
            p = msgpack.packb(
                rng.choice(
                    [
                        {"zenav": 1},
                        ["zenav", "LaserScan", 1],
                        ["zenav", "LaserScan", 1, [1, 2]],
                        42,
                        "x" * 50,
                        ["zenav", "LaserScan", 1, {**body, "ranges": "not an array"}],
                        ["zenav", "LaserScan", 1, {k: v for k, v in body.items() if k != "header"}],
                        ["zenav", "LaserScan", 1, {**body, "extra": 1}],
                        ["zenav", "LaserScan", 1, {**body, "angle_min": True}],
                        ["zenav", "LaserScan", 99, body],
                    ]
                ),
                use_bin_type=True,
            )
        elif kind == 3:  # wrong / unknown type names, or a valid message of another type
            p = rng.choice(
                [
                    msgpack.packb(
                        ["zenav", rng.choice(["Nope", "", "laserscan"]), 1, body], use_bin_type=True
                    ),
                    msgpack.packb(["zenav", 5, 1, body], use_bin_type=True),
                    encode(Text(data="I am not a scan")),
                ]
            )
        elif kind == 4:  # huge declared array sizes / bad array headers
            shape = rng.choice([(2**62,), (2**40, 2**40), (0, 2**63), (1 << 20,), (3, 3, 3, 3, 3)])
            dtype = rng.choice(["float32", "float32", "object", "float128", "<U8"])
            ext = _array_ext(dtype, shape, rng.randbytes(rng.randint(0, 64)))
            p = msgpack.packb(["zenav", "LaserScan", 1, {**body, "ranges": ext}], use_bin_type=True)
        else:  # msgpack headers declaring huge lengths with no data behind them
            p = rng.choice(
                [
                    b"\x94\xa5zenav\xa9LaserScan\x01\xdf\xff\xff\xff\xff",
                    b"\xdd\xff\xff\xff\xff",
                    b"\xdb\xff\xff\xff\xff",
                    b"\xc6\x7f\xff\xff\xff",
                    b"\xc9\xff\xff\xff\xff\x01",
                ]
            ) + rng.randbytes(rng.randint(0, 16))
        out.append(p)
    return out


def test_hostile_payloads_are_all_decode_errors():
    for p in hostile_payloads(1000, seed=1):
        with pytest.raises(DecodeError):
            decode(p, LaserScan)


def test_subscriber_survives_1000_hostile_payloads_and_decodes_the_next_valid_one(node_pair, robot_name):
    a, b = node_pair("attacker"), node_pair("victim")
    sub = b.subscribe("scan", LaserScan, mode="queue", queue_size=10)
    cb_got = []
    cb_sub = b.subscribe("scan", LaserScan, callback=cb_got.append, mode="queue")
    raw = a.session.declare_publisher(
        f"zenav/{robot_name}/scan", congestion_control=zenoh.CongestionControl.BLOCK
    )
    wait_for(lambda: raw.matching_status.matching, timeout=30, what="subscriber matched")
    payloads = hostile_payloads(1000, seed=2)
    for p in payloads:
        raw.put(p)
    wait_for(
        lambda: sub.malformed == len(payloads) and cb_sub.malformed == len(payloads),
        timeout=60,
        what=f"1000 malformed counted (got {sub.malformed})",
    )
    assert sub.received == 0
    assert sub.latest() is None
    good = _valid_scan(42)
    a.publisher("scan").publish(good)
    got = sub.get(timeout=30)
    assert got.header.frame_id == "laser#42"
    assert np.array_equal(got.ranges, good.ranges)
    wait_for(lambda: len(cb_got) == 1, timeout=30, what="callback subscriber got the valid scan")
    assert sub.malformed == cb_sub.malformed == 1000


def test_the_warning_names_the_node_that_sent_the_malformed_payload(node_pair, robot_name, caplog):
    """A message of another type on a topic: the warning says which node published it, so a user can find
    the publisher that uses the wrong topic name."""
    a, b = node_pair("wrong_topic_node"), node_pair("victim")
    sub = b.subscribe("scan", LaserScan, mode="queue", queue_size=10)
    pub = a.publisher("scan")
    wait_for(lambda: pub.matching, timeout=30, what="subscriber matched")
    with caplog.at_level("WARNING", logger="zenav.bus"):
        pub.publish(Text(data="I am not a scan"))
        wait_for(lambda: sub.malformed == 1, timeout=30, what="the malformed payload counted")
    assert "from 'wrong_topic_node'" in caplog.text, caplog.text
    assert "'scan'" in caplog.text and "sample key" not in caplog.text, caplog.text
