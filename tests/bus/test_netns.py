"""Multi-host without configuration: two network namespaces joined by a veth pair, default config
(peer mode + multicast scouting, no endpoints). Needs root and `ip`."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import uuid

import pytest
from bushelp import PROCS, REPO, wait_for

pytestmark = pytest.mark.netns


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, check=check, timeout=30)


@pytest.fixture
def two_hosts():
    if os.geteuid() != 0:
        pytest.skip("netns test needs root (ip netns add)")
    if shutil.which("ip") is None:
        pytest.skip("netns test needs the `ip` tool (iproute2)")
    sfx = uuid.uuid4().hex[:6]
    a, b, va, vb = f"zna{sfx}", f"znb{sfx}", f"zva{sfx}", f"zvb{sfx}"
    try:
        _ip("netns", "add", a)
        _ip("netns", "add", b)
        _ip("link", "add", va, "type", "veth", "peer", "name", vb)
        _ip("link", "set", va, "netns", a)
        _ip("link", "set", vb, "netns", b)
        for ns, dev, addr in ((a, va, "10.77.0.1/24"), (b, vb, "10.77.0.2/24")):
            _ip("-n", ns, "addr", "add", addr, "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
    except subprocess.CalledProcessError as e:
        for ns in (a, b):
            _ip("netns", "del", ns, check=False)
        pytest.skip(f"cannot create network namespaces here: {e.stderr.strip()}")
    try:
        yield {"a": a, "b": b, "va": va, "vb": vb}
    finally:
        for ns in (a, b):  # deleting a namespace also deletes its veth end
            _ip("netns", "del", ns, check=False)


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
    _ip("-n", two_hosts["a"], "link", "set", two_hosts["va"], "down")
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
    _ip("-n", two_hosts["a"], "link", "set", two_hosts["va"], "up")
    _ip("-n", two_hosts["a"], "route", "replace", "224.0.0.0/4", "dev", two_hosts["va"])
    listener.expect(
        lambda s: s.split()[:3] == ["LIVE", "+", token],
        timeout=60,
        what="talker back after link up",
        start=n_before,
    )
    listener.expect(
        lambda s: s.startswith("MSG"), timeout=60, what="scans again after link up", start=listener.found
    )
