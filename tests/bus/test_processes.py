"""Separate processes over real Zenoh sessions: reliable delivery and liveliness on SIGKILL."""

from __future__ import annotations

import json
import sys
import time

from bushelp import child_env, free_port, proc_argv, wait_for

from common.bus import list_live
from common.zenoh_config import BusConfig
from tests.support import listening


def test_two_processes_exchange_1000_laserscans_with_none_lost(spawn, robot_name):
    port = free_port()
    ep = f"tcp/127.0.0.1:{port}"
    sub = spawn(
        proc_argv("scan_sub", "--n", "1000", "--beams", "720"),
        child_env(robot_name, multicast=False, listen=(ep,)),
    )
    # the publisher connects once the subscriber listens (not into Zenoh's 1-2-4 s connect retries)
    wait_for(lambda: listening(port) or sub.proc.poll() is not None, timeout=120, what="the subscriber listening")
    pub = spawn(
        proc_argv("scan_pub", "--n", "1000", "--beams", "720"),
        child_env(robot_name, multicast=False, connect=(ep,)),
    )
    sub_report = json.loads(sub.expect(lambda s: s.startswith("{"), timeout=120, what="subscriber report"))
    pub_report = json.loads(pub.expect(lambda s: s.startswith("{"), timeout=60, what="publisher report"))
    assert pub_report == {"sent": 1000, "subscriber_got": 1000}
    assert sub_report == {"received": 1000, "in_order": True, "bad": 0, "dropped": 0, "malformed": 0}
    assert pub.wait(30) == 0
    assert sub.wait(30) == 0


def test_liveliness_token_disappears_when_node_process_is_killed(spawn, robot_name, node_pair):
    observer = node_pair("observer")  # listens on the hub port
    ep = observer.config.listen[0]
    child = spawn(
        proc_argv("node", "--name", "victim"), child_env(robot_name, multicast=False, connect=(ep,))
    )
    # `zenav nodes --watch` sees the same thing from yet another process.
    watch = spawn(
        [sys.executable, "-m", "deploy.cli", "nodes", "--watch", "--wait", "0.2"],
        child_env(robot_name, multicast=False, connect=(ep,)),
    )
    child.expect(lambda s: s.startswith("READY"), timeout=60, what="victim ready")
    wait_for(
        lambda: f"{robot_name}/node/victim" in list_live(observer.session, robot_name, timeout=2.0),
        timeout=30,
        what="victim's liveliness token",
    )
    # listed at start ("<robot>  victim") or reported later ("<time> + <robot> victim")
    watch.expect(
        lambda s: s.split()[-2:] == [robot_name, "victim"] and "-" not in s.split(),
        timeout=60,
        what="zenav nodes --watch shows victim",
    )
    t0 = time.monotonic()
    child.kill()  # SIGKILL: no chance to undeclare anything
    wait_for(
        lambda: f"{robot_name}/node/victim" not in list_live(observer.session, robot_name, timeout=2.0),
        timeout=15,
        what="victim's token to disappear",
    )
    gone_after = time.monotonic() - t0
    watch.expect(
        lambda s: s.split()[1:] == ["-", robot_name, "victim"],
        timeout=15,
        what="zenav nodes --watch reports victim gone",
    )
    assert gone_after < 5.0, f"killed node still listed {gone_after:.1f} s later"
    # The observer itself is still there.
    assert f"{robot_name}/node/observer" in list_live(observer.session, robot_name, timeout=2.0)


def test_child_env_reproduces_the_bus_config(robot_name):
    env = child_env(robot_name, multicast=False, connect=("tcp/127.0.0.1:1",))
    cfg = BusConfig.from_env(env)
    assert (cfg.robot, cfg.multicast, cfg.connect) == (robot_name, False, ("tcp/127.0.0.1:1",))
