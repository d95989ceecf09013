"""A static transform broadcaster sends its whole set again every few seconds: a change to the set that a
listener missed (latched messages go best effort; on a congested link a live sample can be dropped) reaches
it anyway. In a CI run the simulator's camera_link -> camera_depth_frame, added after the first send, never
reached the collision monitor, which stayed blind for six minutes ("two unconnected trees")."""

from __future__ import annotations

from bushelp import wait_for

from common.geometry import Transform, Vector3
from common.messages import Header, TransformStamped
from common.tf import StaticTFBroadcaster, TFListener
from common.tf_buffer import TFError


def test_a_change_the_listener_missed_reaches_it_with_the_next_republish(node_pair):
    sender, listener_node = node_pair("static_sender", use_sim_time=False), node_pair("listener", use_sim_time=False)
    listener = TFListener(listener_node)
    static = StaticTFBroadcaster(sender, republish_s=0.2)
    try:
        static.send(TransformStamped(Header(0.0, "base_link"), "camera_link", Transform(Vector3(0.1, 0.0, 0.35))))
        wait_for(lambda: listener.buffer.can_transform("base_link", "camera_link", 0.0), 30, "the first set")
        # the simulator's later edge, as if its live sample had been dropped on the way: only in the set
        with static._lock:
            static._all["camera_depth_frame"] = TransformStamped(Header(0.0, "camera_link"), "camera_depth_frame",
                                                                 Transform())

        def connected() -> bool:
            try:
                listener.buffer.lookup("base_link", "camera_depth_frame", 0.0)
                return True
            except TFError:
                return False

        wait_for(connected, 30, "the missed edge, from a republish")
    finally:
        static.close()
        listener.close()
