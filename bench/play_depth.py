"""`zenav record` then `zenav play` of a VGA depth stream at 30 Hz: frames lost on each leg, rate and gaps.

Run: python bench/play_depth.py [--seconds 10] [--hz 30] [--compression zstd]
Leg 1: a publisher in this process (reliable, so a loss is the recorder's) sends Kinect-like 640x480
float32 DepthImages (~1.2 MB) at --hz for --seconds; `zenav record` (subprocess) writes them to MCAP.
Leg 2: `zenav play` (subprocess) publishes the file; a subscriber in this process counts what arrives.
Both on a private loopback Zenoh bus. Ends with one key=value line, e.g.
record_vga_frames=300 record_vga_drops=0 play_vga_hz=30.0 play_vga_drops=0 play_gap_p99_ms=40.1
"""

from __future__ import annotations

import argparse
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from common.bus import Node  # noqa: E402
from common.messages import DepthImage, Header  # noqa: E402
from common.ports import free_port  # noqa: E402
from common.zenoh_config import BusConfig  # noqa: E402
from deploy.logs.mcap_io import read_records  # noqa: E402
from deploy.stack.process_group import checkout_env  # noqa: E402

TOPIC = "camera/depth/image"


def frames(n: int, seed: int = 0) -> list[np.ndarray]:
    """Kinect-like depth: a wall 3 m ahead, the floor below, millimetre steps, 5 % holes; a few variants."""
    v = np.arange(480, dtype=np.float64)[:, None] - 239.5
    u = np.arange(640, dtype=np.float64)[None, :] - 319.5
    wall = 3.0 + 0.5 * np.clip(u / 525.0, 0.0, None) * np.ones_like(v)
    with np.errstate(divide="ignore"):
        ground = np.where(v > 0, 0.5 * 525.0 / v, np.inf) * np.ones_like(u)
    base = np.minimum(wall, ground)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = np.round((base + rng.normal(0, 0.004, base.shape)) * 1000) / 1000
        d[rng.random(d.shape) < 0.05] = 0.0
        out.append(d.astype(np.float32))
    return out


def _env(robot: str, connect: str) -> dict[str, str]:
    env = checkout_env(drop_zenav=True)
    env.update(ZENAV_ROBOT=robot, ZENAV_MULTICAST="0", ZENAV_CONNECT=connect)
    return env


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)  # reaped children: the subprocess of a leg once it exits
    return ru.ru_utime + ru.ru_stime


def _zenav(*args: str, env: dict) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "deploy.cli", *args], env=env, stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True, cwd=ROOT, start_new_session=True)


def record_leg(out: Path, seconds: float, hz: float, compression: str) -> dict:
    robot, ep = f"bench{uuid.uuid4().hex[:8]}", f"tcp/127.0.0.1:{free_port()}"
    node = Node("depth_pub", config=BusConfig(robot=robot, multicast=False, listen=(ep,)), use_sim_time=False)
    pub = node.publisher(TOPIC, reliable=True)
    cpu0 = _children_cpu()
    proc = _zenav("record", str(out), "--topics", TOPIC, "--compression", compression, "--progress", "0",
                  env=_env(robot, ep))
    try:
        deadline = time.monotonic() + 60
        while not pub._pub.matching_status.matching:  # noqa: SLF001 - wait for the recorder's subscription
            if time.monotonic() > deadline or proc.poll() is not None:
                raise SystemExit(f"recorder did not subscribe: {proc.stderr.read() if proc.poll() else ''}")
            time.sleep(0.02)
        imgs = frames(8)
        n = int(round(seconds * hz))
        t0 = time.monotonic()
        late = 0
        for i in range(n):
            t = t0 + i / hz
            if time.monotonic() > t + 0.5 / hz:
                late += 1
            time.sleep(max(0.0, t - time.monotonic()))
            d = imgs[i % len(imgs)].copy()
            d[0, 0] = float(i)  # frame number
            pub.publish(DepthImage(Header(time.time(), "camera_depth_optical_frame"), d))
        sent_s = time.monotonic() - t0
        time.sleep(1.0)  # the last frames reach the recorder
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
        node.close()
    seqs = [int(r.msg.depth[0, 0]) for r in read_records(out) if r.topic == TOPIC]
    cpu = _children_cpu() - cpu0
    return {"sent": n, "send_hz": n / sent_s, "late_sends": late, "recorded": len(seqs), "cpu_s": cpu,
            "drops": n - len(set(seqs)), "file_mb": out.stat().st_size / 1e6, "rc": proc.returncode, "err": err}


def play_leg(path: Path) -> dict:
    robot, port = f"bench{uuid.uuid4().hex[:8]}", free_port()
    ep = f"tcp/127.0.0.1:{port}"
    node = Node("depth_sub", config=BusConfig(robot=robot, multicast=False, listen=(ep,)), use_sim_time=False)
    got: list[tuple[float, int]] = []
    lock = threading.Lock()

    def on_frame(msg: DepthImage) -> None:
        with lock:
            got.append((time.monotonic(), int(msg.depth[0, 0])))

    sub = node.subscribe(TOPIC, DepthImage, callback=on_frame, mode="queue", queue_size=1000)
    cpu0 = _children_cpu()
    proc = _zenav("play", str(path), "--wait-for", TOPIC, "--quiet", env=_env(robot, ep))
    try:
        _, err = proc.communicate(timeout=300)
        deadline = time.monotonic() + 5  # the last frames in flight
        n = -1
        while time.monotonic() < deadline and n != len(got):
            n = len(got)
            time.sleep(0.3)
    finally:
        if proc.poll() is None:
            proc.kill()
        del sub
        node.close()
    t = np.array([g[0] for g in got])
    seqs = [g[1] for g in got]
    gaps = np.diff(t) * 1e3 if len(t) > 1 else np.zeros(1)
    return {"received": len(got), "unique": len(set(seqs)), "in_order": seqs == sorted(seqs),
            "hz": (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 else 0.0, "gap_p50_ms": float(np.median(gaps)),
            "gap_p99_ms": float(np.percentile(gaps, 99)), "gap_max_ms": float(gaps.max()), "rc": proc.returncode,
            "cpu_s": _children_cpu() - cpu0,
            "err": err, "seqs": seqs}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--hz", type=float, default=30.0)
    ap.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="play_depth_") as tmp:
        out = Path(tmp) / "depth.mcap"
        rec = record_leg(out, args.seconds, args.hz, args.compression)
        play = play_leg(out)
    expected = set(range(rec["sent"]))
    play_drops = len(expected - set(play["seqs"])) - rec["drops"]
    rows = [
        ("record", f"sent {rec['sent']} at {rec['send_hz']:.1f} Hz ({rec['late_sends']} late)",
         f"recorded {rec['recorded']}, lost {rec['drops']}",
         f"{rec['file_mb']:.0f} MB ({args.compression}), recorder CPU {rec['cpu_s']:.1f} s"),
        ("play", f"received {play['received']} at {play['hz']:.1f} Hz", f"lost {play_drops}, "
         f"in order {play['in_order']}", f"gap p50 {play['gap_p50_ms']:.1f} ms p99 {play['gap_p99_ms']:.1f} ms "
         f"max {play['gap_max_ms']:.1f} ms, player CPU {play['cpu_s']:.1f} s"),
    ]
    for r in rows:
        print(f"{r[0]:8} {r[1]:34} {r[2]:28} {r[3]}")
    for leg in (rec, play):
        if leg["rc"] != 0:
            print(f"exit {leg['rc']}: {leg['err'][-2000:]}", file=sys.stderr)
    print(f"record_vga_frames={rec['recorded']} record_vga_drops={rec['drops']} file_mb={rec['file_mb']:.0f} "
          f"play_vga_hz={play['hz']:.1f} play_vga_drops={play_drops} play_gap_p99_ms={play['gap_p99_ms']:.1f} "
          f"play_gap_max_ms={play['gap_max_ms']:.1f} record_cpu_s={rec['cpu_s']:.1f} play_cpu_s={play['cpu_s']:.1f}")
    return 0 if rec["rc"] == 0 and play["rc"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
