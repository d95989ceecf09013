"""Fleet scale: N simulated robots' streams through one Zenoh router to one monitor-like subscriber.

    python bench/fleet_bus.py [--robots 20] [--seconds 20] [--procs 4] [--reliable]

`zenav zenoh router` (multicast off, a private loopback port) is the hub; --procs publisher processes
(Zenoh clients) carry the robots between them, each robot a zenav Node (`zenav/<robot>/...`, the real
Publisher: encode, Zenoh, the default congestion control of its topic) publishing messages of real sizes
at the simulated P3-AT's rates: scan (720-beam LaserScan, 20 Hz), odom (Odometry, 50 Hz), tf
(TFMessage odom->base_link, 50 Hz), local_costmap/costmap (120x120 uint8, 5 Hz), global_costmap/costmap
(200x200 uint8, 1 Hz). One subscriber process (a Zenoh client, like `zenav monitor --robot '*'`)
subscribes to `zenav/*/**` and decodes every sample. Latency = time.time() after decode - header.stamp
(set just before publish; one host, one clock). Sequence numbers travel in header.frame_id; drops =
sent - received distinct. router_cpu_pct = the router process's CPU time / wall time over the run
(100 = one core).
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from common.geometry import Transform  # noqa: E402
from common.messages import Costmap, Header, LaserScan, Odometry, TFMessage, TransformStamped  # noqa: E402
from common.ports import free_port  # noqa: E402
from common.tcp_linger import open_session  # noqa: E402

# topic -> rate (Hz) per robot
STREAMS = {"scan": 20.0, "odom": 50.0, "tf": 50.0, "local_costmap/costmap": 5.0, "global_costmap/costmap": 1.0}


def _client(port: int, robot: str):
    from common.zenoh_config import BusConfig

    return BusConfig(robot=robot, mode="client", multicast=False, connect=(f"tcp/127.0.0.1:{port}",))


def _message(topic: str, seq: int):
    stamp = time.time()
    h = Header(stamp, str(seq))
    if topic == "scan":
        return LaserScan(h, -np.pi, np.pi, 2 * np.pi / 720, 0.0, 0.05, 0.05, 30.0, _SCAN, _ZEROS)
    if topic == "odom":
        return Odometry(h)
    if topic == "tf":
        return TFMessage((TransformStamped(h, "base_link", Transform()),))
    grid = _LOCAL if topic.startswith("local") else _GLOBAL
    return Costmap(h, 0.025, data=grid)


_SCAN = np.random.default_rng(0).uniform(0.1, 30.0, 720).astype(np.float32)
_ZEROS = np.zeros(720, np.float32)
_LOCAL = np.random.default_rng(1).integers(0, 255, (120, 120)).astype(np.uint8)
_GLOBAL = np.random.default_rng(2).integers(0, 255, (200, 200)).astype(np.uint8)


def run_pub(port: int, robots: list[str], start_at: float, seconds: float, reliable: bool) -> int:
    from common.bus import Node

    session = open_session(_client(port, robots[0]).to_zenoh())
    nodes = [Node("fleet_pub", robot=r, config=_client(port, r), session=session, use_sim_time=False) for r in robots]
    pubs = {(n.robot, t): n.publisher(t, reliable=reliable or None) for n in nodes for t in STREAMS}
    deadline = time.monotonic() + 60
    while not all(p._pub.matching_status.matching for p in pubs.values()) and time.monotonic() < deadline:
        time.sleep(0.05)
    rng = np.random.default_rng(abs(hash(robots[0])) % 2**32)
    heap = [(start_at + rng.uniform(0, 1.0 / hz), r, t) for r in robots for t, hz in STREAMS.items()]
    heapq.heapify(heap)
    sent = {f"{r}/{t}": 0 for r in robots for t in STREAMS}
    end = start_at + seconds
    while heap:
        due, r, t = heapq.heappop(heap)
        if due >= end:
            continue
        delay = due - time.time()
        if delay > 0:
            time.sleep(delay)
        key = f"{r}/{t}"
        pubs[(r, t)].publish(_message(t, sent[key]))
        sent[key] += 1
        heapq.heappush(heap, (due + 1.0 / STREAMS[t], r, t))
    print(json.dumps(sent), flush=True)
    time.sleep(1.0)
    os._exit(0)  # noqa: SLF001 - skip the sessions' slow close


def run_sub(port: int, stop_at: float) -> int:
    from common.codec import DecodeError, decode

    session = open_session(_client(port, "fleet_monitor").to_zenoh())
    got: dict[str, set[int]] = {}
    lat: dict[str, list[float]] = {t: [] for t in STREAMS}
    bad = [0]

    def on(sample) -> None:
        try:
            msg = decode(sample.payload.to_bytes())
        except DecodeError:
            bad[0] += 1
            return
        h = msg.transforms[0].header if isinstance(msg, TFMessage) else msg.header
        now = time.time()
        _, robot, topic = str(sample.key_expr).split("/", 2)
        got.setdefault(f"{robot}/{topic}", set()).add(int(h.frame_id))
        lat[topic].append(now - h.stamp)

    sub = session.declare_subscriber("zenav/*/**", on)  # the router is private: every robot here is ours
    print("ready", flush=True)
    time.sleep(max(0.0, stop_at - time.time()))
    sub.undeclare()
    print(json.dumps({"got": {k: len(v) for k, v in got.items()}, "lat": lat, "malformed": bad[0]}), flush=True)
    os._exit(0)  # noqa: SLF001


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def pct(xs, q: float) -> float:
    return float(np.percentile(np.asarray(xs) * 1e3, q)) if len(xs) else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--procs", type=int, default=4, help="publisher processes (robots spread over them)")
    ap.add_argument("--reliable", action="store_true",
                    help="publish every topic reliable=True (Zenoh BLOCK congestion control) instead of the "
                    "stream default (DROP when a send queue stays full for 1 ms)")
    ap.add_argument("--role", default="main", choices=("main", "pub", "sub"), help=argparse.SUPPRESS)
    ap.add_argument("--port", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--names", default="", help=argparse.SUPPRESS)
    ap.add_argument("--at", type=float, default=0.0, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.role == "pub":
        return run_pub(a.port, a.names.split(","), a.at, a.seconds, a.reliable)
    if a.role == "sub":
        return run_sub(a.port, a.at)

    port, prefix = free_port(), "fleet" + uuid.uuid4().hex[:6]
    tmp = Path(tempfile.mkdtemp(prefix="zenav_fleet_"))
    conf = tmp / "router.json5"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env["PYTHONPATH"] = str(REPO)
    subprocess.run([sys.executable, "-m", "deploy.cli", "zenoh", "config", "router", "--listen",
                    f"tcp/127.0.0.1:{port}", "--no-multicast", "-o", str(conf)], env=env, cwd=REPO, check=True,
                   stdout=subprocess.DEVNULL)
    me = [sys.executable, __file__, "--port", str(port)]
    procs: list[subprocess.Popen] = []
    try:
        router = subprocess.Popen([sys.executable, "-m", "deploy.cli", "zenoh", "router", "--config", str(conf)],
                                  stdout=subprocess.PIPE, text=True, env=env, cwd=REPO)
        procs.append(router)
        assert "listening" in router.stdout.readline(), "the router did not start"
        start_at = time.time() + 8.0  # publishers connect and match first
        stop_at = start_at + a.seconds + 3.0  # the subscriber drains a little after the last send
        sub = subprocess.Popen([*me, "--role", "sub", "--at", str(stop_at)],
                               stdout=subprocess.PIPE, text=True, env=env)
        procs.append(sub)
        assert sub.stdout.readline().strip() == "ready", "the subscriber did not start"
        robots = [f"{prefix}r{i:02d}" for i in range(a.robots)]
        extra = ["--at", str(start_at), "--seconds", str(a.seconds), *(["--reliable"] if a.reliable else [])]
        pubs = [subprocess.Popen([*me, "--role", "pub", "--names", ",".join(robots[i :: a.procs]), *extra],
                                 stdout=subprocess.PIPE, text=True, env=env) for i in range(min(a.procs, a.robots))]
        procs += pubs
        time.sleep(max(0.0, start_at - time.time()))
        c0, w0 = cpu_seconds(router.pid), time.monotonic()
        time.sleep(a.seconds)
        router_cpu = 100.0 * (cpu_seconds(router.pid) - c0) / (time.monotonic() - w0)
        sent: dict[str, int] = {}
        for p in pubs:
            sent.update(json.loads(p.communicate(timeout=120)[0].strip().splitlines()[-1]))
        res = json.loads(sub.communicate(timeout=120)[0].strip().splitlines()[-1])
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    return report(a, sent, res, router_cpu)


def report(a, sent: dict[str, int], res: dict, router_cpu: float) -> int:
    got, lat = res["got"], res["lat"]
    mode = "reliable=True (BLOCK)" if a.reliable else "stream default (DROP)"
    print(f"{a.robots} robots over {a.procs} publisher processes -> zenav zenoh router -> 1 subscriber of "
          f"zenav/*/** (decodes all), {a.seconds:.0f} s, publishers {mode}; latency = receive after decode - stamp")
    print(f"{'topic':<24}{'Hz/robot':>9}{'sent':>8}{'recv':>8}{'drop %':>8}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}")
    tot_sent = tot_got = 0
    for t, hz in STREAMS.items():
        s = sum(n for k, n in sent.items() if k.split("/", 1)[1] == t)
        g = sum(n for k, n in got.items() if k.split("/", 1)[1] == t)
        tot_sent, tot_got = tot_sent + s, tot_got + g
        drop = 100.0 * (s - g) / s if s else float("nan")
        print(f"{t:<24}{hz:>9.0f}{s:>8}{g:>8}{drop:>8.2f}{pct(lat[t], 50):>9.2f}{pct(lat[t], 99):>9.2f}"
              f"{pct(lat[t], 100):>9.2f}")
    all_lat = [x for xs in lat.values() for x in xs]
    drop = 100.0 * (tot_sent - tot_got) / tot_sent if tot_sent else float("nan")
    rate = tot_sent / a.seconds
    print(f"{'all':<24}{rate / a.robots:>9.0f}{tot_sent:>8}{tot_got:>8}{drop:>8.2f}{pct(all_lat, 50):>9.2f}"
          f"{pct(all_lat, 99):>9.2f}{pct(all_lat, 100):>9.2f}")
    print(f"router CPU {router_cpu:.1f} % of one core; {rate:.0f} messages/s; malformed {res['malformed']}")
    print(f"fleet_robots={a.robots} fleet_drop_pct={drop:.2f} fleet_p50_ms={pct(all_lat, 50):.2f} "
          f"fleet_p99_ms={pct(all_lat, 99):.2f} router_cpu_pct={router_cpu:.1f} fleet_msgs_per_s={rate:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
