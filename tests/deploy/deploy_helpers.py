"""Helpers for the deploy tests. Run as a script it is a fake robot:

    python tests/deploy/deploy_helpers.py fakerobot [--skew S]

publishing scan (10 Hz), odom and tf odom→base_link (20 Hz) with header stamps time.time() + skew,
on the bus configured by ZENAV_* (prints READY once up)."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from pathlib import Path

from deploy.stack.process_group import checkout_env
from tests.support import free_port  # noqa: F401

REPO = Path(__file__).resolve().parents[2]
HELPER = str(Path(__file__).resolve())


def env_for(robot: str | None = None, **zenav: str) -> dict[str, str]:
    """Environment for a child: no inherited ZENAV_*, this checkout on PYTHONPATH, then ``zenav``."""
    env = checkout_env(drop_zenav=True)
    if robot:
        env["ZENAV_ROBOT"] = robot
    env.update(zenav)
    return env


def zenav(args: list[str], env: dict[str, str], timeout: float = 60, prefix: list[str] = ()):
    """Run the zenav CLI in a child process; returns CompletedProcess (text)."""
    return subprocess.run([*prefix, sys.executable, "-m", "deploy.cli", *args], env=env, cwd=str(REPO),
                          capture_output=True, text=True, timeout=timeout)


def start(argv: list[str], env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen(argv, env=env, cwd=str(REPO), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def wait_line(proc: subprocess.Popen, prefix: str, timeout: float = 60) -> str:
    """Read stdout lines until one starts with ``prefix`` (fails on exit; readline blocks, so the
    deadline is checked between lines — the child prints its line or dies)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        line = proc.stdout.readline()
        if line.startswith(prefix):
            return line
        if not line and proc.poll() is not None:
            raise AssertionError(f"child exited {proc.returncode}: {proc.stderr.read()[-2000:]}")
    raise AssertionError(f"no line {prefix!r} within {timeout} s")


def stop(proc: subprocess.Popen) -> None:
    import signal

    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(10)


def fakerobot(skew: float) -> int:
    sys.path.insert(0, str(REPO))
    import numpy as np

    from common.bus import Node
    from common.geometry import Transform
    from common.messages import Header, LaserScan, Odometry, TFMessage, TransformStamped

    node = Node("fake_base")
    scan, odom, tf = node.publisher("scan"), node.publisher("odom"), node.publisher("tf")
    i = [0]

    def fast() -> None:
        h = Header(time.time() + skew, "odom")
        odom.publish(Odometry(h, "base_link", Transform()))
        tf.publish(TFMessage((TransformStamped(h, "base_link", Transform()),)))
        i[0] += 1
        if i[0] % 2 == 0:
            r = np.full(180, 2.0, np.float32)
            scan.publish(LaserScan(Header(time.time() + skew, "laser"), -1.57, 1.57, 3.14 / 180, 0, 0.1,
                                   0.05, 10.0, r, np.zeros(180, np.float32)))

    node.timer(0.05, fast)
    print("READY", flush=True)
    try:
        while True:
            time.sleep(3600)
    finally:
        node.close()


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["fakerobot"])
    ap.add_argument("--skew", type=float, default=0.0)
    a = ap.parse_args()
    sys.exit(fakerobot(a.skew))
