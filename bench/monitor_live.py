"""Is the browser view live? The monitor's output rate and the web viewer's lag, on this machine.

The simulated P3-AT patrols the room (`zenav goal --waypoints deploy/missions/room_patrol.yaml --loop`) on the
known map, with `zenav monitor --serve-web` on a private loopback bus and, beside it, a second `zenav monitor
--save` with the same rates whose file growth is the monitor's output rate (what a viewer has to take in;
given the web's rates, deploy/monitor/pacing.py WEB_RATES). After --warmup seconds the page is opened in
headless Chromium (its software rasterizer, as on this machine) with the Rerun web viewer, and every few
seconds a screenshot is taken:
  - in Rerun's map view, the map's extent on screen (its free and unknown cells) calibrates screen to
    world (a top-down view, +y up);
  - the robot's footprint outline (blue) is found there and placed in the world: it must lie on the
    robot's true track (within 0.15 m of the simulator's ground truth of the last two minutes);
  - the lag is how far the viewer's time cursor (its ``time_update`` events, the ``stamp`` timeline it
    follows live) is behind the robot's clock at the capture.
The whole map in view is checked too: the map's extent must lie inside the view, with a margin.

    python bench/monitor_live.py [--warmup 20] [--samples 12] [--monitor-arg=--rate=LaserScan=2 ...]
    python bench/monitor_live.py --demo --warmup 0 --samples 40   # zenav demo --serve-web, across its world switch
    python bench/monitor_live.py --warmup 120 --shot docs/monitor-web.png   # the README's picture

Ends with monitor_out_mb_s=… viewer_lag_s=… (the median of the samples) viewer_lag_max_s=… viewer_catchup_s=…
(from the viewer being up until every later sample is under 5 s behind: the history a late page takes in)
viewer_lag_live_s=… (the median from then on) viewer_pose_ago_s=… panel_pose_ago_s=… (how long ago ground truth was
where Rerun's map view / our map panel draws the robot, within 0.15 m; the median of the last 5 samples; 20 = not
within 20 s) robot_found=k/n robot_on_track=k/n map_in_view=k/n
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit.nav_stack import MASTER_DIR, ROBOT_CONFIG, NavProc  # noqa: E402
from testkit.wait import free_port, wait_until  # noqa: E402
from testkit.webrig import ZENAV, Page, map_mask, rerun_map_view, rgb  # noqa: E402

PATROL = REPO / "deploy" / "missions" / "room_patrol.yaml"
LIVE_S = 5.0  # issue 31: "Rerun's latency indicator under 5 s"
FOOTPRINT_RGB = (60, 120, 255)  # deploy/monitor/loggers.log_polygon


def locate(img: np.ndarray, box, world_box) -> tuple[tuple[float, float] | None, bool]:
    """(the robot's world x, y from its footprint outline on screen, or None; the whole map inside the view
    with a margin). ``world_box``: the map's (x0, y0, x1, y1) in metres."""
    x0, y0, x1, y1 = box
    mask = map_mask(img, box)
    cols, rows = np.nonzero(mask.mean(axis=0) > 0.2)[0], np.nonzero(mask.mean(axis=1) > 0.2)[0]
    if len(cols) < 10 or len(rows) < 10:
        return None, False
    c0, c1, r0, r1 = cols[0], cols[-1], rows[0], rows[-1]
    c = img[y0:y1, x0:x1]
    # the whole map in view: its free interior (white, under the costmap's bands) clear of the view's edges
    white = (c[..., 0] > 200) & (c[..., 1] > 200) & (c[..., 2] > 200)
    wc, wr = np.nonzero(white.mean(axis=0) > 0.2)[0], np.nonzero(white.mean(axis=1) > 0.2)[0]
    inside = bool(len(wc) and len(wr) and wc[0] > 10 and wr[0] > 10 and wc[-1] < (x1 - x0) - 10
                  and wr[-1] < (y1 - y0) - 10)
    blue = (np.abs(c[..., 0] - FOOTPRINT_RGB[0]) < 30) & (np.abs(c[..., 1] - FOOTPRINT_RGB[1]) < 30) \
        & (np.abs(c[..., 2] - FOOTPRINT_RGB[2]) < 30)
    ys, xs = np.nonzero(blue)
    if len(xs) < 8:
        return None, inside
    wx0, wy0, wx1, wy1 = world_box
    wx = wx0 + (xs.mean() - c0) / max(c1 - c0, 1) * (wx1 - wx0)
    wy = wy1 - (ys.mean() - r0) / max(r1 - r0, 1) * (wy1 - wy0)  # screen rows grow downwards, +y up
    return (float(wx), float(wy)), inside


def drawn_ago(truth: np.ndarray, where, t_cap: float, near_m: float = 0.15, window_s: float = 20.0) -> float:
    """How long before the capture ``t_cap`` ground truth was within ``near_m`` of the drawn position, the
    nearest such time to the capture (``truth`` rows: wall time received, stamp, x, y; negative: received
    after the capture); ``window_s`` when it was nowhere near within that many seconds either side."""
    rows = truth[np.abs(truth[:, 0] - t_cap) < window_s]
    close = rows[np.hypot(rows[:, 2] - where[0], rows[:, 3] - where[1]) < near_m]
    return float((t_cap - close[np.argmin(np.abs(t_cap - close[:, 0])), 0])) if len(close) else window_s


def median(v) -> float:
    return float(np.median(v)) if len(v) else float("inf")


def page_map_box(page: Page) -> tuple[float, float, float, float]:
    """The map's (x0, y0, x1, y1) in metres, as the page has it now (the demo switches worlds)."""
    mp = page.js("JSON.stringify({x: zenav.map.origin.x, y: zenav.map.origin.y, w: zenav.map.width,"
                 " h: zenav.map.height, r: zenav.map.resolution})")
    d = json.loads(mp)
    return d["x"], d["y"], d["x"] + d["w"] * d["r"], d["y"] + d["h"] * d["r"]


def catch_up(since: list[float], lags: list[float], live_s: float = LIVE_S) -> tuple[float, float]:
    """(seconds from the page's viewer being up to the first sample from which every sample is under
    ``live_s`` behind, the median lag from there on); (inf, inf) when the view never stays live."""
    for i in range(len(lags)):
        if all(v < live_s for v in lags[i:]):
            return since[i], float(np.median(lags[i:]))
    return float("inf"), float("inf")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--warmup", type=float, default=20.0, help="seconds of patrol before the page is opened")
    ap.add_argument("--samples", type=int, default=12)
    ap.add_argument("--every", type=float, default=4.0, help="seconds between screenshots")
    ap.add_argument("--demo", action="store_true",
                    help="watch `zenav demo --serve-web` (the room, then the corridor) instead of the patrol")
    ap.add_argument("--shot", type=Path, help="also write the last screenshot here (the README's picture)")
    ap.add_argument("--monitor-arg", action="append", default=[], help="extra argument for both monitors")
    a = ap.parse_args(argv)
    from common.bus import Node
    from common.messages import Odometry
    from common.zenoh_config import BusConfig
    from deploy.monitor.pacing import WEB_RATES
    from deploy.stack.world_maps import export_world_map

    tmp = Path(tempfile.mkdtemp(prefix="zenav-monitor-live-"))
    web_rates = ",".join(f"{k}={v:g}" for k, v in WEB_RATES.items())  # what --serve-web logs
    robot = f"live{os.getpid()}"
    hub = f"tcp/127.0.0.1:{free_port()}"
    web, grpc = free_port(), free_port()
    base = {**os.environ, "ZENAV_ROBOT": robot, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
            "ZENAV_CONNECT": hub, "PYTHONPATH": str(REPO)}
    base.pop("ZENAV_USE_SIM_TIME", None)
    procs: list[NavProc] = []
    if a.demo:  # the demo runs its own private bus: join it at the endpoint it prints
        procs.append(NavProc(tmp / "demo.log", [*ZENAV, "demo", "--robot", robot, "--serve-web", str(web),
                                                "--workdir", str(tmp / "demo")], base))
        hub = wait_until(lambda: re.search(r"\[demo\] bus: (\S+)", procs[0].log()), 60, "the demo's bus").group(1)
    node = Node("monitor_live_bench", config=BusConfig(robot=robot, **({"connect": (hub,)} if a.demo else
                                                                        {"listen": (hub,)}), multicast=False),
                use_sim_time=False)
    truth: list[tuple[float, float, float, float]] = []  # (wall time, stamp, x, y)
    node.subscribe("ground_truth", Odometry, mode="queue",
                   callback=lambda m: truth.append((time.time(), m.header.stamp, m.pose2d.x, m.pose2d.y)))
    if not a.demo:
        map_yaml = export_world_map("room", tmp / "maps")
        procs += [NavProc(tmp / f"{n}.log", argv, base) for n, argv in (
            ("robot", [*ZENAV, "robot", "--config", str(ROBOT_CONFIG), "--world", "room"]),
            ("master", [*ZENAV, "master", "--config", str(MASTER_DIR / "p3at_known_map.yaml"), "--map",
                        str(map_yaml)]),
            ("monitor", [*ZENAV, "monitor", "--serve-web", str(web), "--grpc-port", str(grpc), *a.monitor_arg]),
            ("recorder", [*ZENAV, "monitor", "--save", str(tmp / "out.rrd"), "--rate", web_rates,
                          *a.monitor_arg]))]
    page = None
    try:
        wait_until(lambda: len(truth) > 0, 120, "the simulator's ground truth")
        if not a.demo:
            procs.append(NavProc(tmp / "patrol.log", [*ZENAV, "goal", "--waypoints", str(PATROL), "--loop"], base))
        rrd = tmp / "out.rrd"
        time.sleep(a.warmup)
        size0, t0 = (rrd.stat().st_size if rrd.exists() else 0), time.monotonic()
        page = Page(tmp, web)
        page.open_page(viewer=True)
        page.wait(lambda: page.js("!!(window.zenav && zenav.map && zenav.rerun !== 'starting')"), 150.0,
                  "the page with the Rerun viewer")
        t_ready = time.monotonic()
        lags, found, in_view, on_track, since, taken = [], 0, 0, 0, [], 0
        drawn: list = []  # (capture time, where Rerun's map view draws the robot, where our map panel does)
        for k in range(a.samples):
            if a.demo and "the run is over" in procs[0].log():
                print(f"the demo's run is over after {k} samples", file=sys.stderr)
                break
            time.sleep(a.every)
            t_req = time.time()
            img = rgb(page.screenshot())
            taken += 1
            t_cap = (t_req + time.time()) / 2  # the frame was drawn between request and answer
            where, inside = locate(img, rerun_map_view(img), page_map_box(page))
            in_view += inside
            cursor = page.js("(() => { const e = zenav.viewerEvents.filter((v) => v.includes('time_update'));"
                             " return e.length ? JSON.parse(e[e.length - 1]).time / 1e9 : null; })()")
            if where is None:
                print(f"sample {k + 1}: robot not found on screen; map in view: {inside}", file=sys.stderr)
                continue
            panel = json.loads(page.js("JSON.stringify(zenav.state && zenav.state.pose)") or "null")
            recent = np.array([r for r in truth if r[0] > t_cap - 120.0] or truth)
            drawn.append((t_cap, where, (panel["x"], panel["y"]) if panel else None))
            found += 1
            off = float(np.min(np.hypot(recent[:, 2] - where[0], recent[:, 3] - where[1])))
            on_track += off < 0.15
            # the lag: how far the viewer's time cursor (the stamp timeline, followed live) is behind the
            # robot's clock at the capture (its latest ground truth stamp then)
            now_stamp = recent[recent[:, 0] <= t_cap][-1, 1]
            lag = now_stamp - cursor if cursor is not None else float("inf")
            lags.append(lag)
            since.append(time.monotonic() - t_ready)
            print(f"sample {k + 1}: robot drawn at ({where[0]:.2f}, {where[1]:.2f}), {off:.2f} m from its true "
                  f"track; the view {lag:.1f} s behind the robot's clock; map in view: {inside}", file=sys.stderr,
                  flush=True)
        # the demo has no second monitor to measure (nan)
        out_mb_s = ((rrd.stat().st_size if rrd.exists() else 0) - size0) / 1e6 / (time.monotonic() - t0) \
            if not a.demo else float("nan")
        lag = float(np.median(lags)) if lags else float("inf")
        catchup, live_lag = catch_up(since, lags)
        # how long ago ground truth was where each draws the robot, with the ground truth received since (the
        # bench's own subscriber may get it later than the monitor)
        time.sleep(2.0)
        track = np.array(truth)
        rerun_ago = [drawn_ago(track, w, t) for t, w, _ in drawn]
        panel_ago = [drawn_ago(track, p, t) for t, _, p in drawn if p is not None]
        print("ground truth was where Rerun draws the robot ... s before each capture: "
              + " ".join(f"{v:.1f}" for v in rerun_ago) + "; where our panel draws it: "
              + " ".join(f"{v:.1f}" for v in panel_ago), file=sys.stderr)
        print(f"monitor_out_mb_s={out_mb_s:.3f} viewer_lag_s={lag:.1f} "
              f"viewer_lag_max_s={max(lags) if lags else float('inf'):.1f} viewer_catchup_s={catchup:.0f} "
              f"viewer_lag_live_s={live_lag:.1f} viewer_pose_ago_s={median(np.abs(rerun_ago[-5:])):.1f} "
              f"panel_pose_ago_s={median(np.abs(panel_ago[-5:])):.1f} robot_found={found}/{taken} "
              f"robot_on_track={on_track}/{taken} map_in_view={in_view}/{taken}")
        shot = page.screenshot()
        for path in (tmp / "last.png", *([a.shot] if a.shot else [])):
            path.write_bytes(shot)
            print(f"last screenshot: {path}", file=sys.stderr)
    finally:
        if page is not None:
            page.close()
        for p in reversed(procs):
            p.stop()
        node.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
