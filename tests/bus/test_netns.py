"""Multi-host without configuration: two network namespaces joined by a veth pair, default config
(peer mode + multicast scouting, no endpoints). Needs root and `ip`."""

from __future__ import annotations

import os
import sys
import time

import pytest
from bushelp import PROCS, REPO, wait_for

from tests.support import ip, two_netns

pytestmark = pytest.mark.netns


@pytest.fixture
def two_hosts():
    with two_netns("n", "10.77.0") as hosts:
        yield hosts


def _env(robot: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(
        PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1", ZENAV_ROBOT=robot, ZENAV_SHM="0"
    )  # /dev/shm is shared between namespaces: force the real link
    return env


def test_two_hosts_discover_each_other_with_default_config_and_notice_link_loss(two_hosts, spawn, robot_name):
    env = _env(robot_name)
    ns = ["ip", "netns", "exec"]

    talker = spawn(
        [*ns, two_hosts["a"], sys.executable, PROCS, "talker", "--name", "talker", "--rate", "20"], env
    )
    listener = spawn([*ns, two_hosts["b"], sys.executable, PROCS, "listener", "--name", "listener"], env)
    talker.expect(lambda s: s.startswith("READY"), timeout=60, what="talker ready")
    listener.expect(lambda s: s.startswith("READY"), timeout=60, what="listener ready")
    token = f"zenavlive/{robot_name}/node/talker"
    listener.expect(lambda s: s.split()[:3] == ["LIVE", "+", token], timeout=60, what="talker's token in B")
    listener.expect(lambda s: s.startswith("MSG"), timeout=60, what="scans in B")
    wait_for(lambda: sum(s.startswith("MSG") for s in listener.lines) >= 10, timeout=60, what="10 scans in B")
    seqs = [int(s.split()[1]) for s in listener.lines if s.startswith("MSG")]
    assert seqs == sorted(seqs)
    assert len(set(seqs)) == len(seqs)

    # Cut the link: the talker's liveliness must be lost in about a second (lease 1000 ms).
    t_down = time.time()
    ip("-n", two_hosts["a"], "link", "set", two_hosts["va"], "down")
    n_before = len(listener.lines)
    line = listener.expect(
        lambda s: s.split()[:3] == ["LIVE", "-", token],
        timeout=20,
        what="talker's token lost after link down",
    )
    lost_after = float(line.split()[3]) - t_down
    print(f"liveliness lost {lost_after:.2f} s after the link went down")
    assert 0.3 < lost_after < 2.5, f"link loss noticed after {lost_after:.2f} s"

    # Link back: the hosts find each other again by themselves, and data flows.
    ip("-n", two_hosts["a"], "link", "set", two_hosts["va"], "up")
    ip("-n", two_hosts["a"], "route", "replace", "224.0.0.0/4", "dev", two_hosts["va"])
    listener.expect(
        lambda s: s.split()[:3] == ["LIVE", "+", token],
        timeout=60,
        what="talker back after link up",
        start=n_before,
    )
    listener.expect(
        lambda s: s.startswith("MSG"), timeout=60, what="scans again after link up", start=listener.found
    )
