"""Bus benchmark: two processes on loopback (explicit tcp endpoint, multicast off).

    python bench/bus.py [--scans 1000] [--seconds 10] [--stages]

Measures, through the real Node API (encode -> Zenoh -> decode -> subscriber callback):
  * one-way latency of a 720-beam LaserScan (paced at 200 Hz), and as a baseline the same number of
    bytes through Zenoh alone (raw put -> raw subscriber callback: no codec, no checks, no delivery thread),
  * one-way latency of a 640x480 float32 DepthImage, and the sustained receive rate and drop count of
    VGA depth images published at 30 Hz for --seconds.
One-way latency = time.time() in the subscriber's callback (after decode) minus header.stamp, set
with time.time() just before publish (encode included). Both processes are on this host, so they
share one clock. Sequence numbers travel in header.frame_id; drops = published - received.
--stages: also split the scan's latency into message + encode, Zenoh, decode + checks and the hop to the
callback thread (bench/bus_stages.py; a few clock reads per message, so off for the headline figure).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from bench import bus_stages  # noqa: E402
from common.bus import Node  # noqa: E402
from common.codec import encode  # noqa: E402
from common.messages import DepthImage, Header, LaserScan, Text  # noqa: E402
from common.ports import free_port  # noqa: E402
from common.zenoh_config import BusConfig  # noqa: E402

RAW_KEY = "benchraw/{robot}/scan"  # the Zenoh-only baseline's key (not a zenav topic)


# -- subscriber process ----------------------------------------------------------------------------
def run_sub(robot: str, port: int, stages: bool) -> int:
    entered: dict[str, tuple[float, float]] = {}
    if stages:
        bus_stages.time_receive("scan", entered)
    node = Node(
        "bench_sub", config=BusConfig(robot=robot, multicast=False, listen=(f"tcp/127.0.0.1:{port}",))
    )
    rec: dict[str, list] = {"scan": [], "depth": []}
    arrivals: list[float] = []
    lock = threading.Lock()

    def on(topic: str):
        def cb(m) -> None:
            now = time.time()
            with lock:
                rec[topic].append((m.header.frame_id, now - m.header.stamp))
                if topic == "depth" and not m.header.frame_id.startswith("depth-"):
                    arrivals.append(time.monotonic())

        return cb

    raw: list[tuple[int, float]] = []

    def on_raw(sample) -> None:  # Zenoh alone: no decode, no checks, no hop to a delivery thread
        now = time.time()
        head = bytes(sample.payload.to_bytes()[:32]).split(b" ")
        raw.append((int(head[0]), now - float(head[1])))

    raw_sub = node.session.declare_subscriber(RAW_KEY.format(robot=robot), on_raw)
    subs = {
        "scan": node.subscribe("scan", LaserScan, callback=on("scan"), mode="queue", queue_size=100),
        "depth": node.subscribe("depth", DepthImage, callback=on("depth"), mode="queue", queue_size=100),
    }
    report = node.subscribe("ctl", Text, mode="queue")
    node.publisher("ready", latched=True).publish(Text(data="ready"))
    want = json.loads(report.get(timeout=300).data)  # {"scan": n, "depth": n} sent in total
    end = time.monotonic() + 10  # each subscription has its own delivery thread: let them drain
    while time.monotonic() < end and (any(len(rec[t]) < want[t] for t in rec) or len(raw) < want["raw"]):
        time.sleep(0.01)
    raw_sub.undeclare()
    with lock:
        out = {t: {"rec": rec[t], "dropped": subs[t].dropped, "malformed": subs[t].malformed} for t in rec}
        out["depth"]["arrivals"] = arrivals
        out["raw"] = raw
        out["entered"] = entered
    print(json.dumps(out), flush=True)
    node.close()
    return 0


# -- publisher (main) ------------------------------------------------------------------------------
def pct(xs: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(xs) * 1e3, q)) if xs else float("nan")


def paced(n: int, hz: float, fn) -> float:
    """Call fn(i) n times at hz (absolute deadlines, no drift); returns the achieved send rate."""
    t0 = time.perf_counter()
    for i in range(n):
        delay = t0 + i / hz - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        fn(i)
    return n / (time.perf_counter() - t0) if n > 1 else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--role", default="pub", choices=("pub", "sub"))
    ap.add_argument("--robot", default="bench" + uuid.uuid4().hex[:8])
    ap.add_argument("--port", type=int, default=0)
    ap.add_argument("--stages", action="store_true", help="time the scan's path stage by stage")
    a = ap.parse_args()
    if a.role == "sub":
        return run_sub(a.robot, a.port, a.stages)

    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    child = subprocess.Popen(
        [sys.executable, __file__, "--role", "sub", "--robot", a.robot, "--port", str(port)]
        + (["--stages"] if a.stages else []),
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        return bench(a, port, child)
    finally:
        if child.poll() is None:
            child.kill()


def bench(a, port: int, child: subprocess.Popen) -> int:
    cfg = BusConfig(robot=a.robot, multicast=False, connect=(f"tcp/127.0.0.1:{port}",))
    deadline = time.monotonic() + 60
    while True:  # the child may not be listening yet
        try:
            node = Node("bench_pub", config=cfg)
            break
        except Exception:  # noqa: BLE001 - zenoh.ZError: connection refused
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)
    scan_pub, depth_pub, ctl = node.publisher("scan"), node.publisher("depth"), node.publisher("ctl", reliable=True)
    node.subscribe("ready", Text).wait_first(timeout=60)
    for p in (scan_pub, depth_pub, ctl):
        while not p._pub.matching_status.matching:
            time.sleep(0.01)

    sent: dict[str, tuple[float, float, float]] = {}
    if a.stages:
        scan_pub._pub = bus_stages.TimedPut(scan_pub._pub)
    beams = 720
    ranges = np.random.default_rng(0).uniform(0.1, 30.0, beams).astype(np.float32)
    inten = np.zeros(beams, np.float32)

    def send_scan(i: int) -> None:
        stamp = time.time()
        scan_pub.publish(
            LaserScan(
                Header(stamp, f"scan{i}"),
                -np.pi,
                np.pi,
                2 * np.pi / beams,
                0.0,
                0.1,
                0.05,
                30.0,
                ranges,
                inten,
            )
        )
        if a.stages:
            sent[f"scan{i}"] = (stamp, *scan_pub._pub.last)

    depth = np.random.default_rng(1).uniform(0.3, 8.0, (480, 640)).astype(np.float32)

    def send_depth(i: int) -> None:
        depth_pub.publish(DepthImage(Header(time.time(), f"depth{i}"), depth))

    raw_pub = node.session.declare_publisher(RAW_KEY.format(robot=a.robot))
    blob = bytes(len(encode(LaserScan(Header(0.0, "scan0"), ranges=ranges, intensities=inten))))

    def send_raw(i: int) -> None:  # the same bytes count as an encoded scan, stamped like one
        head = f"{i} {time.time():.6f} ".encode()
        raw_pub.put(head + blob[len(head):])

    while not raw_pub.matching_status.matching:
        time.sleep(0.01)
    paced(50, 200.0, lambda i: send_raw(-1 - i))
    paced(a.scans, 200.0, send_raw)
    paced(50, 200.0, lambda i: send_scan(-1 - i))  # warm-up (not counted)
    paced(10, 30.0, lambda i: send_depth(-1 - i))
    scan_rate = paced(a.scans, 200.0, send_scan)
    n_depth = int(round(a.seconds * 30))
    depth_rate = paced(n_depth, 30.0, send_depth)
    ctl.publish(Text(data=json.dumps({"scan": 50 + a.scans, "depth": 10 + n_depth, "raw": 50 + a.scans})))
    out, _ = child.communicate(timeout=120)
    res = json.loads(out.strip().splitlines()[-1])
    node.close()

    s, d = res["scan"], res["depth"]
    raw_lat = [x for q, x in res["raw"] if q >= 0]
    s_rec = [(q, x) for q, x in s["rec"] if not q.startswith("scan-")]  # "scan-N": warm-up
    d_rec = [(q, x) for q, x in d["rec"] if not q.startswith("depth-")]
    s_got, d_got = {q for q, _ in s_rec}, {q for q, _ in d_rec}
    s_lat, d_lat = [x for _, x in s_rec], [x for _, x in d_rec]
    arr = np.asarray(d["arrivals"])
    d_hz = (len(arr) - 1) / (arr[-1] - arr[0]) if len(arr) > 1 else 0.0
    scan_drops, depth_drops = a.scans - len(s_got), n_depth - len(d_got)

    rows = [
        (
            "LaserScan 720 beams",
            f"{scan_rate:.0f}",
            len(s_got),
            scan_drops,
            pct(s_lat, 50),
            pct(s_lat, 99),
            pct(s_lat, 100),
            "-",
        ),
        (
            "DepthImage 640x480 f32",
            f"{depth_rate:.1f}",
            len(d_got),
            depth_drops,
            pct(d_lat, 50),
            pct(d_lat, 99),
            pct(d_lat, 100),
            f"{d_hz:.2f}",
        ),
        (
            "Zenoh alone, same bytes",
            "200",
            len(raw_lat),
            a.scans - len(raw_lat),
            pct(raw_lat, 50),
            pct(raw_lat, 99),
            pct(raw_lat, 100),
            "-",
        ),
    ]
    print(
        "two processes, loopback tcp, multicast off; one-way latency = subscriber time.time() after decode "
        "- header.stamp (set before encode+publish)"
    )
    print(
        f"{'message':<24}{'sent Hz':>8}{'recv':>6}{'drops':>6}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}"
        f"{'recv Hz':>9}"
    )
    for r in rows:
        print(f"{r[0]:<24}{r[1]:>8}{r[2]:>6}{r[3]:>6}{r[4]:>9.3f}{r[5]:>9.3f}{r[6]:>9.3f}{r[7]:>9}")
    extra = ""
    if a.stages:
        delivered = {q: sent[q][0] + x for q, x in s_rec if q in sent}
        p50 = bus_stages.stage_p50_ms(sent, res["entered"], delivered)
        print("LaserScan stages, p50 ms: " + ", ".join(f"{k} {v:.3f}" for k, v in p50.items()))
        extra = " " + " ".join(f"stage_{k.replace('+', '_').replace(' ', '_')}_p50_ms={v:.3f}" for k, v in p50.items())
    print(
        f"scan_p50_ms={pct(s_lat, 50):.3f} scan_p99_ms={pct(s_lat, 99):.3f} zenoh_raw_p50_ms={pct(raw_lat, 50):.3f} "
        f"depth_vga_p50_ms={pct(d_lat, 50):.3f} depth_vga_hz={d_hz:.2f} depth_vga_drops={depth_drops}{extra}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
