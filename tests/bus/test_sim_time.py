"""Simulated time: a node with use_sim_time follows the `clock` topic (faster than real time)."""

from __future__ import annotations

import threading
import time

from bushelp import wait_for

from common.messages import Clock


def test_timer_follows_sim_clock_published_5x_faster_than_real_time(node_pair):
    sim = node_pair("sim")
    clock_pub = sim.publisher("clock")
    node = node_pair("planner", use_sim_time=True)
    assert node.clock.simulated
    assert node.clock.now() == 0.0
    wait_for(lambda: clock_pub._pub.matching_status.matching, timeout=30, what="clock subscriber matched")
    ticks: list[float] = []
    node.timer(0.1, lambda: ticks.append(node.clock.now()))

    speed, step = 5.0, 0.005  # 5x real time; one clock message per 5 simulated ms
    sim_t, sim_end = 0.0, 3.0
    wall0 = time.monotonic()
    stop = threading.Event()
    while sim_t < sim_end and not stop.is_set():
        sim_t = round(sim_t + step, 6)
        clock_pub.publish(Clock(sim_t))
        # pace at `speed` x real time (pacing only; correctness does not depend on it)
        delay = wall0 + sim_t / speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    wall = time.monotonic() - wall0
    wait_for(lambda: node.clock.now() >= sim_end, timeout=30, what="node clock reached the end")
    # The timer ran on simulated time: ~10 ticks per simulated second, in far less wall time.
    in_window = [t for t in ticks if 1.0 <= t < 3.0]
    assert 16 <= len(in_window) <= 21, (len(in_window), ticks)
    # The timer keeps its grid (as ROS timers do): a tick run late is followed by one on time, so one gap
    # may be short, but two gaps in a row always span a period — no burst. A callback starved for 0.1 s of
    # wall time on a loaded machine reads a clock 0.5 s later (5x).
    gaps = [round(b - a, 3) for a, b in zip(in_window, in_window[1:])]
    assert all(0 < g < 0.6 for g in gaps), f"gaps {gaps}"
    assert all(a + b >= 0.099 for a, b in zip(gaps, gaps[1:])), f"a burst of ticks: gaps {gaps}"
    assert wall < sim_end * 0.8, f"clock publishing took {wall:.1f} s wall for {sim_end} s simulated"
    # Stopped clock: no more ticks though wall time passes.
    n = len(ticks)
    t_end = time.monotonic() + 0.5
    while time.monotonic() < t_end:
        node.clock.now()
        time.sleep(0.05)
    assert len(ticks) <= n + 1


def test_a_node_on_auto_sim_time_takes_the_robots_clock_from_its_first_message(node_pair):
    """use_sim_time="auto" (``zenav goal``, ``zenav explore``): wall time until a simulator publishes
    ``clock``, then its time; a TF listener made before follows the switch. A wall-clock node drops what is
    stamped 300 s ahead of it: a simulator at --speed 2 is that far ahead of the wall in five minutes."""
    from common import messages as m
    from common.geometry import Pose2D
    from common.tf import TFListener

    sim = node_pair("sim")
    clock_pub, tf_pub = sim.publisher("clock"), sim.publisher("tf")
    node = node_pair("explore", use_sim_time="auto")
    tf = TFListener(node)
    assert not node.clock.simulated and node.clock.now() > 1e9  # wall time
    ahead = time.time() + 1000.0  # a simulator 1000 s ahead of the wall

    def published(t: float) -> bool:
        clock_pub.publish(Clock(t))
        return node.clock.simulated and node.clock.now() == t

    wait_for(lambda: published(ahead), timeout=30, what="the node on the simulator's clock")
    wait_for(lambda: published(ahead + 0.5), timeout=30, what="the node following the clock")
    edge = m.TFMessage((m.TransformStamped(m.Header(ahead + 0.5, "odom"), "base_link",
                                           Pose2D(1.0, 2.0, 0.0).to_transform()),))

    def got_tf() -> bool:
        tf_pub.publish(edge)
        return tf.buffer.can_transform("odom", "base_link", ahead + 0.5)

    wait_for(got_tf, timeout=30, what="a transform stamped 1000 s ahead of the wall, taken")
