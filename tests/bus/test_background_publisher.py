"""A background publisher never makes its caller wait on the network (common/bus_sender.py): the
robot-side states (collision, motor state, the collision monitor's state) are published from control
loops, and a reliable put toward a master behind a just-cut link waits up to Zenoh's wait_before_close.
ci82/ci83 saw the simulated robot's ground truth stop for over 10 s after a cut: its loop was blocked in
such a put."""

from __future__ import annotations

import threading
import time

from bushelp import wait_for

from common.bus_sender import LatestSender
from common.messages import Header, MotorState


def test_send_returns_at_once_while_the_put_waits_and_the_newest_message_goes_next():
    release, puts = threading.Event(), []

    def put(data: bytes) -> None:  # a put stuck on a congested link until released
        release.wait(10.0)
        puts.append(data)

    sender = LatestSender(put, "state")
    t0 = time.monotonic()
    for i in range(5):
        sender.send(bytes([i]))
    took = time.monotonic() - t0
    release.set()
    wait_for(lambda: puts and puts[-1] == bytes([4]), 10, "the newest message put")
    sender.close()
    assert took < 0.5  # five sends while the first put waited: none of them waited
    assert puts[-1] == bytes([4]) and puts == sorted(puts)  # in order, ending with the newest
    assert len(puts) + sender.superseded == 5  # each message sent or superseded by a newer one


def test_a_background_latched_publisher_delivers_over_the_bus(node_pair):
    pub_node, sub_node = node_pair("sim", use_sim_time=False), node_pair("watcher", use_sim_time=False)
    pub = pub_node.publisher("motor_state", latched=True, background=True)
    sub = sub_node.subscribe("motor_state", MotorState, mode="latest")
    wait_for(lambda: pub.matching, 30, "the subscriber matched")
    for enabled in (False, True):
        pub.publish(MotorState(Header(time.time(), "base_link"), enabled))
    wait_for(lambda: sub.latest() is not None and sub.latest().enabled, 30, "the newest state")
    late = node_pair("late", use_sim_time=False).subscribe("motor_state", MotorState, mode="latest")
    wait_for(lambda: late.latest() is not None and late.latest().enabled, 30, "the latched state, late")
