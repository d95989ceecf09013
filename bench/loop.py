"""End-to-end latency: scan stamp -> first cmd_vel computed from a costmap that includes the scan.

    python bench/loop.py [--seconds 60] [--controller-frequency HZ] [--costmap-frequency HZ] [--on-data]

`zenav robot` (simulated P3-AT, room world, its Kinect -> depth_to_scan -> `scan`) and `zenav master`
(known map, DWA: local_costmap and move_base as separate processes) run as separate process groups on a
private loopback Zenoh bus; this process is a third peer that sends goals back and forth across the
room and records, with its wall clock at arrival:
  * `clock` (sim time -> wall time: a stamp t happened when Clock(t) was published, i.e. when it
    arrived here minus one bus hop),
  * `scan` (stamps of the scans the local costmap reads),
  * `local_costmap/costmap_trace` (after each local costmap: its stamp, newest observation stamp in it),
  * `move_base/cmd_trace` (after each cmd_vel: the stamp of the local costmap it was computed from).
For each scan taken while move_base was controlling: the first costmap whose newest observation is at
least as new as the scan, then the first cmd_vel computed from that costmap or a later one.
scan_to_cmd = arrival of that cmd_trace - wall time of the scan's stamp; split into
  sensor (stamp -> scan here: depth image, depth_to_scan, two hops), costmap (-> costmap_trace here:
  waiting for the update timer, the update, publishing), controller (-> cmd_trace here: waiting for the
  control cycle, the cycle). bus_hop = one-way latency of a 720-beam LaserScan between this process and
  a child process on the same bus while the stack runs (as bench/bus.py measures it).
"""

from __future__ import annotations

import argparse
import bisect
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from common.messages import Clock, Header, LaserScan, Scalar, Text  # noqa: E402


def run_hop(robot: str, port: int) -> int:
    """Child: receives hop_probe scans, prints one-way latencies (JSON) when told to stop."""
    from common.bus import Node
    from common.zenoh_config import BusConfig

    node = Node("loop_hop", config=BusConfig(robot=robot, multicast=False, connect=(f"tcp/127.0.0.1:{port}",)),
                use_sim_time=False)
    lat: list[float] = []
    node.subscribe("hop_probe", LaserScan, callback=lambda m: lat.append(time.time() - m.header.stamp),
                   mode="queue")
    ctl = node.subscribe("hop_ctl", Text, mode="queue")
    node.publisher("hop_ready", latched=True).publish(Text(data="ready"))
    ctl.get(timeout=3600)
    time.sleep(0.5)
    print(json.dumps(lat), flush=True)
    os._exit(0)  # noqa: SLF001 - skip the session's slow close


class Rec:
    """Arrival wall time and message of one topic."""

    def __init__(self, node, topic: str, kind) -> None:
        self.items: list[tuple[float, object]] = []
        node.subscribe(topic, kind, callback=lambda m: self.items.append((time.time(), m)), mode="queue",
                       queue_size=100000)


def _hz(items) -> float:
    """Median rate of a stream (arrivals), gaps over 1 s (goal changes) left out."""
    gaps = np.diff([t for t, _ in items])
    gaps = gaps[gaps < 1.0]
    return 1.0 / float(np.median(gaps)) if len(gaps) else 0.0


def pct(xs, q: float) -> float:
    return float(np.percentile(np.asarray(xs) * 1e3, q)) if len(xs) else float("nan")


def analyse(clock, scans, cmaps, cmds, hop: float) -> dict[str, list[float]]:
    ck_val = np.array([m.clock for _, m in clock])
    ck_wall = np.array([t for t, _ in clock]) - hop
    order = np.argsort(ck_val)
    ck_val, ck_wall = ck_val[order], ck_wall[order]
    cm_obs = [m.value for _, m in cmaps]  # newest observation stamp: non-decreasing
    cmd_wall = [t for t, _ in cmds]
    out: dict[str, list[float]] = {"total": [], "sensor": [], "costmap": [], "controller": [], "missed": []}
    for t_scan, s in scans:
        stamp = s.header.stamp
        i = int(np.searchsorted(ck_val, stamp))
        if i >= len(ck_val) or abs(ck_val[i] - stamp) > 0.02:
            continue
        w0 = ck_wall[i]
        k = bisect.bisect_left(cmd_wall, w0 - 0.5)  # move_base controlling when the scan was taken?
        if k >= len(cmds) or cmd_wall[k] > w0:
            continue
        j = bisect.bisect_left(cm_obs, stamp)
        if j >= len(cmaps):
            continue
        t_cm, cm = cmaps[j]
        first = bisect.bisect_left(cmd_wall, t_cm)
        c = next((n for n in range(first, len(cmds)) if cmds[n][1].value >= cm.header.stamp), None)
        if c is None:
            continue
        out["missed"].append(float(c > first))  # a cycle ran after the costmap was out, on an older one
        t_cmd = cmds[c][0]
        out["total"].append(t_cmd - w0)
        out["sensor"].append(t_scan - w0)
        out["costmap"].append(t_cm - t_scan)
        out["controller"].append(t_cmd - t_cm)
    return out


def _costmap_override(make, values: dict):
    """Wrap the stack's master config writer: the local costmap's parameters updated with ``values``."""
    import yaml

    def wrapped(*args, **kw) -> Path:
        out = make(*args, **kw)
        cfg = yaml.safe_load(out.read_text())
        params = cfg["nodes"]["local_costmap"]["params"]
        spec = yaml.safe_load(Path(params["specific"]).read_text())
        spec["local_costmap"].update(values)
        f = out.with_name("local_costmap_override.yaml")
        f.write_text(yaml.safe_dump(spec))
        params["specific"] = str(f)
        out.write_text(yaml.safe_dump(cfg, sort_keys=False))
        return out

    return wrapped


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=60.0, help="measuring time while driving (default 60)")
    ap.add_argument("--controller-frequency", type=float, default=0.0,
                    help="override move_base's controller_frequency (default: the shipped 10 Hz)")
    ap.add_argument("--costmap-frequency", type=float, default=0.0,
                    help="override the local costmap's update_frequency (default: the shipped 5 Hz)")
    ap.add_argument("--on-data", action="store_true",
                    help="zenav's event-driven mode: the local costmap updates when a scan arrives "
                         "(update_on_observation) and move_base cycles when a costmap arrives "
                         "(control_on_costmap), each at most at its frequency")
    ap.add_argument("--role", default="main", choices=("main", "hop"), help=argparse.SUPPRESS)
    ap.add_argument("--robot", default="", help=argparse.SUPPRESS)
    ap.add_argument("--port", type=int, default=0, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.role == "hop":
        return run_hop(a.robot, a.port)
    import testkit.nav_stack as nav_e2e_stack
    from testkit.nav_stack import NavStack, publisher_ready, world_goals

    tmp = Path(tempfile.mkdtemp(prefix="zenav_loop_"))
    mb = {"controller_frequency": a.controller_frequency} if a.controller_frequency > 0 else None
    local = {"update_frequency": a.costmap_frequency} if a.costmap_frequency > 0 else {}
    if a.on_data:
        mb = {**(mb or {}), "control_on_costmap": True}
        local["update_on_observation"] = True
    if local:
        mb = mb or {"controller_frequency": 10.0}  # the shipped value; makes the stack write a config copy
        nav_e2e_stack.master_config_for = _costmap_override(nav_e2e_stack.master_config_for, local)
    print("starting zenav robot + zenav master (room world, DWA) ...", flush=True)
    stack = NavStack(tmp, "room", "dwa", move_base=mb)
    node = stack.node
    port = int(node.config.listen[0].rsplit(":", 1)[1])
    child = subprocess.Popen([sys.executable, __file__, "--role", "hop", "--robot", stack.robot, "--port",
                              str(port)], stdout=subprocess.PIPE, text=True,
                             env={k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")})
    try:
        clock, scans = Rec(node, "clock", Clock), Rec(node, "scan", LaserScan)
        cmaps, cmds = Rec(node, "local_costmap/costmap_trace", Scalar), Rec(node, "move_base/cmd_trace", Scalar)
        loop = Rec(node, "move_base/loop_time", Scalar)
        probe, hop_ctl = node.publisher("hop_probe"), node.publisher("hop_ctl", reliable=True)
        node.subscribe("hop_ready", Text).wait_first(timeout=60)
        publisher_ready(probe)
        goals = world_goals("room")
        stop = threading.Event()

        def drive() -> None:
            for name in ("across_obstacle", "back_to_start") * 100:
                if stop.is_set():
                    return
                stack.goal(*goals[name], timeout=120.0)

        threading.Thread(target=drive, daemon=True).start()
        ranges = np.random.default_rng(0).uniform(0.1, 30.0, 720).astype(np.float32)
        t0 = time.monotonic()
        i = 0
        while time.monotonic() - t0 < a.seconds:  # the hop probe at a scan's rate, under the stack's load
            probe.publish(LaserScan(Header(time.time(), f"p{i}"), -np.pi, np.pi, 2 * np.pi / 720, 0.0, 0.1,
                                    0.05, 30.0, ranges, np.zeros(720, np.float32)))
            i += 1
            time.sleep(0.05)
        stop.set()
        hop_ctl.publish(Text(data="stop"))
        hops = json.loads(child.communicate(timeout=60)[0].strip().splitlines()[-1])[20:]
    finally:
        if child.poll() is None:
            child.kill()
        stack.close()
    hop = float(np.median(hops)) if hops else 0.0
    r = analyse(clock.items, scans.items, cmaps.items, cmds.items, hop)
    n_cmd = len(cmds.items)
    cm_hz, cmd_hz = _hz(cmaps.items), _hz(cmds.items)
    print(f"room world, DWA; {len(scans.items)} scans ({_hz(scans.items):.1f} Hz), {len(cmaps.items)} local "
          f"costmaps ({cm_hz:.1f} Hz), {n_cmd} cmd_vel ({cmd_hz:.1f} Hz while driving); {len(r['total'])} "
          f"scans taken while controlling, traced to a cmd_vel; the first control cycle after the costmap "
          f"went out had used an older one for {100 * np.mean(r['missed'] or [0]):.0f} % of them")
    print(f"{'segment':<44}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}")
    rows = [("bus hop (720-beam LaserScan, one way)", hops),
            ("sensor: stamp -> scan delivered", r["sensor"]),
            ("costmap: -> costmap including it published", r["costmap"]),
            ("controller: -> first cmd_vel from it", r["controller"]),
            ("  of which: move_base cycle (loop_time)", [m.value for _, m in loop.items]),
            ("scan_to_cmd: stamp -> cmd_vel", r["total"])]
    for name, xs in rows:
        print(f"{name:<44}{pct(xs, 50):>9.2f}{pct(xs, 99):>9.2f}{pct(xs, 100):>9.2f}")
    mode = "on_data" if a.on_data else "timers"
    print(f"mode={mode} scan_to_cmd_p50_ms={pct(r['total'], 50):.1f} scan_to_cmd_p99_ms={pct(r['total'], 99):.1f} "
          f"bus_hop_p50_ms={pct(hops, 50):.3f} sensor_p50_ms={pct(r['sensor'], 50):.1f} "
          f"costmap_p50_ms={pct(r['costmap'], 50):.1f} controller_p50_ms={pct(r['controller'], 50):.1f} "
          f"traced_scans={len(r['total'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
