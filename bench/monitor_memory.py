"""Memory of `zenav monitor --serve-web` on a long run: does the monitor grow?

Starts the simulated P3-AT in the room, the master (map server, AMCL, costmaps, move_base) and
`zenav monitor --serve-web` on a private loopback bus, drives the robot around the room's goals in a loop
(the demo's rates), polls the page's /api/state as an open page does (5 Hz), and samples the monitor's
RSS every --every seconds (with --browser also the page in headless Chromium with the Rerun web viewer:
Chromium's total RSS). The growth rate is fitted over the second half of the run and
extrapolated to 8 h. The last line is one key=value summary.

    python bench/monitor_memory.py [--minutes 10] [--every 10] [--history-limit 512MiB] [--browser]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from deploy.cli.monitor import HISTORY_LIMIT  # noqa: E402
from testkit.nav_stack import ROBOT_CONFIG, NavProc, world_goals  # noqa: E402
from testkit.wait import free_port, wait_until  # noqa: E402
from testkit.webrig import ZENAV, Page, master_yaml  # noqa: E402

START = (-2.2, 0.0, 0.0)  # robot_side/worlds/room.yaml


def rss_mb(pid: int) -> float:
    """Resident set size of one process (MiB)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def group_rss_mb(pgid: int) -> float:
    """Summed RSS of the processes of a process group (Chromium's renderers, GPU process, ...)."""
    total = 0.0
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if os.getpgid(int(d.name)) == pgid:
                    total += rss_mb(int(d.name))
            except (OSError, ValueError):
                continue
    return total


def growth_per_hour(t_s: np.ndarray, mb: np.ndarray) -> float:
    """Least-squares slope (MiB/h) of the second half of the samples."""
    half = t_s >= t_s[-1] / 2
    if half.sum() < 2:
        return float("nan")
    return float(np.polyfit(t_s[half] / 3600.0, mb[half], 1)[0])


class Stack:
    """Robot + master + monitor as process groups on a private bus; a test peer drives goals."""

    def __init__(self, tmp: Path, history_limit: str | None) -> None:
        from common.bus import Node
        from common.zenoh_config import BusConfig

        self.tmp, self.procs = tmp, []
        self.robot = f"monmem{os.getpid()}"
        hub, robot_p, master_p, mon_p = free_port(), free_port(), free_port(), free_port()
        self.web, self.grpc = free_port(), free_port()
        self.node = Node("monitor_memory_bench", config=BusConfig(robot=self.robot, listen=(f"tcp/127.0.0.1:{hub}",),
                                                                   multicast=False), use_sim_time=False)
        base = {**os.environ, "ZENAV_ROBOT": self.robot, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
                "PYTHONPATH": str(REPO)}
        base.pop("ZENAV_USE_SIM_TIME", None)
        hub_ep = f"tcp/127.0.0.1:{hub}"
        self._start("robot", [*ZENAV, "robot", "--config", str(ROBOT_CONFIG), "--world", "room"],
                    {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{robot_p}", "ZENAV_CONNECT": hub_ep})
        self._start("master", [*ZENAV, "master", "--config", str(master_yaml(tmp, START))],
                    {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{master_p}",
                     "ZENAV_CONNECT": f"{hub_ep},tcp/127.0.0.1:{robot_p}"})
        self.monitor = self._start("monitor", [*ZENAV, "monitor", "--serve-web", str(self.web), "--grpc-port",
                                               str(self.grpc)]
                                   + (["--history-limit", history_limit] if history_limit else []),
                                   {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{mon_p}", "ZENAV_CONNECT": hub_ep})
        self.stop = threading.Event()
        self.goals_done = 0

    def _start(self, name: str, argv: list[str], env: dict) -> NavProc:
        p = NavProc(self.tmp / f"{name}.log", argv, env)
        self.procs.append(p)
        return p

    def dead(self) -> str:
        return next((f"{p.log_path.name} exited:\n{p.log()}" for p in self.procs if not p.alive()), "")

    def state(self) -> dict | None:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{self.web}/api/state", timeout=5) as r:
                return json.load(r)
        except OSError:
            return None

    def drive(self) -> None:
        """The room's goals in a loop until stopped (a goal that fails is just the next one's start)."""
        from deploy.stack.goals import send_goal

        goals = list(world_goals("room").values())
        i = 0
        while not self.stop.is_set():
            x, y, yaw = goals[i % len(goals)]
            send_goal(self.node, x, y, yaw, "map", 120.0, echo=lambda *_: None, cancel=self.stop)
            self.goals_done, i = self.goals_done + 1, i + 1

    def poll_page(self) -> None:
        """What an open page does: /api/state at 5 Hz (and /api/map when its version changes)."""
        version = None
        while not self.stop.wait(0.2):
            st = self.state()
            if st and st.get("map_version") != version:
                version = st["map_version"]
                with urllib.request.urlopen(f"http://127.0.0.1:{self.web}/api/map", timeout=5) as r:
                    r.read()

    def close(self) -> None:
        self.stop.set()
        for p in reversed(self.procs):
            p.stop()
        self.node.close()


class Browser(Page):
    """Headless Chromium with the page open (the Rerun web viewer running). Sampled from /proc only: a
    DevTools call waits behind the viewer's busy main thread, and the JS heap is not where the viewer's
    memory is (wasm linear memory, a few MB of JS heap)."""

    def __init__(self, tmp: Path, web: int) -> None:
        super().__init__(tmp, web)
        self.open_page(viewer=True)

    def rss_mb(self) -> float:
        return group_rss_mb(self.chromium.pid)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0, help="how long to run (after the stack is up)")
    ap.add_argument("--every", type=float, default=10.0, help="seconds between samples")
    ap.add_argument("--history-limit", default=None,
                    help="the monitor's --history-limit (Rerun's gRPC history buffer; default: the monitor's)")
    ap.add_argument("--browser", action="store_true",
                    help="also open the page (with the Rerun web viewer) in headless Chromium and sample it")
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="monitor_memory_"))
    stack = Stack(tmp, a.history_limit)
    browser = None
    try:
        wait_until(lambda: (s := stack.state()) and s.get("pose") and s.get("move_base"), 180.0,
                   "the monitor's page showing the robot and move_base", period=0.5, alive=stack.dead)
        for fn in (stack.drive, stack.poll_page):
            threading.Thread(target=fn, daemon=True).start()
        if a.browser:
            browser = Browser(tmp, stack.web)
        pid = stack.monitor.proc.pid
        print(f"monitor pid {pid}, logs in {tmp}; {a.minutes:.0f} min, a sample every {a.every:.0f} s",
              file=sys.stderr)
        print(f"{'t_s':>6} {'monitor_rss_mb':>15} {'goals':>6}" + (f" {'chromium_mb':>12}" if browser else ""),
              flush=True)
        t0, samples = time.monotonic(), []
        while True:
            t = time.monotonic() - t0
            if dead := stack.dead():
                raise SystemExit(dead)
            row = [t, rss_mb(pid)] + ([browser.rss_mb()] if browser else [])
            samples.append(row)
            print(f"{t:6.0f} {row[1]:15.1f} {stack.goals_done:6d}"
                  + (f" {row[2]:12.1f}" if browser else ""), flush=True)
            if t >= a.minutes * 60:
                break
            time.sleep(max(0.0, a.every - (time.monotonic() - t0 - t)))
    finally:
        try:
            if browser is not None:
                browser.close()
        finally:
            stack.close()
    s = np.array(samples)
    rate = growth_per_hour(s[:, 0], s[:, 1])
    est = s[-1, 1] + rate * max(0.0, 8.0 - s[-1, 0] / 3600.0)
    line = (f"minutes={s[-1, 0] / 60:.1f} goals={stack.goals_done} monitor_rss_start_mb={s[0, 1]:.0f} "
            f"monitor_rss_end_mb={s[-1, 1]:.0f} monitor_rss_max_mb={s[:, 1].max():.0f} growth_mb_per_h={rate:.1f} "
            f"rss_8h_est_mb={est:.0f} history_limit={a.history_limit or HISTORY_LIMIT}")
    if browser is not None:
        line += (f" chromium_rss_end_mb={s[-1, 2]:.0f}"
                 f" chromium_growth_mb_per_h={growth_per_hour(s[:, 0], s[:, 2]):.1f}")
    print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
