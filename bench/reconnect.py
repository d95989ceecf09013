"""Delivery across link cuts: how long after a healed partition a goal gets through, and whether any is lost.

    sudo python bench/reconnect.py [--cycles 200] [--hog 2] [--seed 1]

Two network namespaces joined by a user-space link (testkit/linkem.py: real IP packets, dropped while
partitioned), a master-side peer (goal topic, acknowledged goal service, latched map, status stream) and
a robot-side peer, each its own process with zenav's default Zenoh configuration (peer, multicast
scouting, 1 s lease). With ``--children agent`` (ZENAV_CHILDREN=agent) each side is laid out as an agent lays
out its nodes (zenav's default): one peer process (the agent) and the others its clients over loopback; with
``--children mesh`` every process is a peer. Each cycle cuts the link for 0.3, 1.5 or 4 s (shorter
than the lease, about it, well beyond it), heals it, and at once:
  - a put stream on the goal topic, from the robot's existing publisher or from one declared right
    after the heal (alternating): how long until the first put arrives is the route's recovery time;
  - a goal through the acknowledged service (common/delivery.py, as `zenav goal` sends it), 20 s deadline;
  - a new subscriber of the latched map (as `zenav record` started after the heal), 20 s deadline;
  - the master's 10 Hz status stream to the robot's subscriber declared at the start (as move_base/status
    to `zenav goal`): how long until the first message after the heal arrives, 30 s deadline.
``--hog N`` runs N busy processes beside it (the 2-core machine loaded as by a second test worker).
Ends with ``reconnect_cycles=… goals_lost=… latched_lost=… stream_lost=… status_lost=… recovery_p50_s=…
recovery_p99_s=…``.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import random
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit.line_proc import LineProc  # noqa: E402

CUTS_S = (0.3, 1.5, 4.0)


def wait_for(cond, timeout: float):
    """``cond()``'s first truthy value within ``timeout`` s (looked at least once, even with no time left)."""
    end = time.monotonic() + timeout
    while True:
        if (v := cond()):
            return v
        if time.monotonic() >= end:
            return None
        time.sleep(0.01)


def _hog() -> None:
    while True:
        pass


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--cycles", type=int, default=200)
    ap.add_argument("--hog", type=int, default=2, help="busy processes beside the run (default 2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--peers", type=int, default=3,
                    help="bystander processes per side (each one more Zenoh session, as a real stack's nodes)")
    ap.add_argument("--autoconnect", choices=("greater-zid", "always"), default="greater-zid",
                    help="which scouted peer dials (ZENAV_AUTOCONNECT; default greater-zid, zenav's default; "
                         "always: both, as Zenoh does)")
    ap.add_argument("--children", choices=("agent", "mesh"), default="agent",
                    help="each side as one agent peer with client nodes (default, as zenav's agents run "
                         "their nodes) or as a mesh of peers (ZENAV_CHILDREN=mesh)")
    ap.add_argument("--logs", type=Path, default=Path("/tmp/zenav_reconnect"), help="peer logs go here")
    args = ap.parse_args()
    if os.geteuid() != 0:
        print("bench/reconnect.py needs root (network namespaces)", file=sys.stderr)
        return 2
    args.logs.mkdir(parents=True, exist_ok=True)
    rng = random.Random(args.seed)
    sfx = uuid.uuid4().hex[:6]
    ns_m, ns_r = f"zrcm{sfx}", f"zrcr{sfx}"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1", ZENAV_ROBOT=f"rc{sfx}", ZENAV_SHM="0",
               ZENAV_AUTOCONNECT=args.autoconnect)
    procs: list[LineProc] = []
    hogs: list[multiprocessing.Process] = []
    rows: list[dict] = []
    try:
        for ns in (ns_m, ns_r):
            subprocess.run(["ip", "netns", "add", ns], check=True)
        link = LineProc([sys.executable, str(REPO / "testkit/linkem.py"), ns_m, "10.79.0.1/24", ns_r, "10.79.0.2/24"],
                    env, args.logs / "link.log")
        procs.append(link)
        assert wait_for(lambda: link.first("READY") or (link.lines and link.lines[0][0] == "READY"), 30), "link"

        def peer_proc(ns: str, role: str, arg: str = "", via: str = "") -> LineProc:
            cmd = ["ip", "netns", "exec", ns, sys.executable, "-m", "testkit.reconnect_peer", role,
                   *([arg] if arg else [])]
            p = LineProc(cmd, {**env, "ZENAV_VIA_AGENT": via}, args.logs / f"{role}{len(procs)}.log")
            procs.append(p)
            return p
        hubs = {}
        if args.children == "agent":  # the agents first: their nodes connect to them
            for ns in (ns_m, ns_r):
                local = "tcp/127.0.0.1:7450"  # the namespace's own loopback, as an agent's (pick_agent_endpoint)
                hubs[ns] = (local, peer_proc(ns, "agent", local))
            assert wait_for(lambda: all(h.first("READY") for _, h in hubs.values()), 60), "agents did not start"

        def peer(ns: str, role: str) -> LineProc:
            return peer_proc(ns, role, via=hubs[ns][0] if ns in hubs else "")

        master, robot = peer(ns_m, "master"), peer(ns_r, "robot")
        extras = [peer(ns, "extra") for ns in (ns_m, ns_r) for _ in range(args.peers)]
        assert wait_for(lambda: all(p.first("READY") for p in (master, robot, *extras)), 120), "peers did not start"

        robot.send("stream s0")
        assert wait_for(lambda: master.first("GOT", prefix="s0:"), 60), "no route before the first cut"
        robot.send("stop s0")
        for _ in range(args.hog):
            h = multiprocessing.Process(target=_hog, daemon=True)
            h.start()
            hogs.append(h)
        t_start = time.monotonic()
        for i in range(1, args.cycles + 1):
            cut = rng.choice(CUTS_S)
            fresh = i % 2 == 0
            assert link.command("partition", 10), "link: partition"
            time.sleep(cut)  # the partition's length is the experiment's input, not a wait for a condition
            assert link.command("heal", 10), "link: heal"
            t_heal = time.time()
            robot.send(f"{'fresh' if fresh else 'stream'} s{i}")
            robot.send(f"call c{i}")
            robot.send(f"latched l{i}")
            robot.send(f"await a{i}")
            got = wait_for(lambda i=i: master.first("GOT", prefix=f"s{i}:"), 30)
            robot.send(f"stop s{i}")
            ack = wait_for(lambda i=i: robot.first("ACK", f"c{i}") or robot.first("NOACK", f"c{i}"), 30)
            lat = wait_for(lambda i=i: robot.first("LATCHED", f"l{i}"), 20)
            back = wait_for(lambda i=i: robot.first("STATUS", f"a{i}"), max(0.0, t_heal + 30 - time.time()))
            row = {"cut": cut, "fresh": fresh, "recovery": float(got[0]) - t_heal if got else None,
                   "ack": (float(ack[0]) - t_heal) if ack and ack[1] == "ACK" else None,
                   "latched": float(lat[0]) - t_heal if lat else None,
                   "status": float(back[0]) - t_heal if back else None}
            rows.append(row)
            if row["ack"] is None:  # say what was seen: a query path lost while puts get through?
                why = " ".join(ack[2:]) if ack else "no answer line at all"
                srv = ("the master's service ran" if master.first("SRV", f"c{i}")
                       else "the query never reached the master")
                print(f"  goal c{i} not acknowledged: {srv}; {why}", flush=True)
            fmt = lambda v: f"{v:6.2f}" if v is not None else "  LOST"  # noqa: E731
            print(f"cycle {i:4d}/{args.cycles}  cut {cut:3.1f} s  {'fresh' if fresh else 'old  '} publisher  "
                  f"route {fmt(row['recovery'])} s  ack {fmt(row['ack'])} s  latched {fmt(row['latched'])} s  "
                  f"status {fmt(row['status'])} s"
                  f"  ({time.monotonic() - t_start:5.0f} s)", flush=True)
    finally:
        for h in hogs:
            h.kill()
        for p in reversed(procs):
            p.stop()
        for ns in (ns_m, ns_r):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
    print(f"\n{'cut s':>5} {'publisher':9} {'n':>4} {'route p50':>9} {'p99':>6} {'max':>6} {'lost':>4} | "
          f"{'ack p50':>7} {'max':>6} {'lost':>4} | {'latched max':>11} {'lost':>4} | {'status max':>10} {'lost':>4}")
    for cut in CUTS_S:
        for fresh in (False, True):
            sel = [r for r in rows if r["cut"] == cut and r["fresh"] == fresh]
            if not sel:
                continue
            rec = [r["recovery"] for r in sel if r["recovery"] is not None]
            ack = [r["ack"] for r in sel if r["ack"] is not None]
            lat = [r["latched"] for r in sel if r["latched"] is not None]
            sta = [r["status"] for r in sel if r["status"] is not None]
            q = lambda xs, p: f"{np.percentile(xs, p):.2f}" if xs else "-"  # noqa: E731
            print(f"{cut:5.1f} {'fresh' if fresh else 'old':9} {len(sel):4d} {q(rec, 50):>9} {q(rec, 99):>6} "
                  f"{q(rec, 100):>6} {len(sel) - len(rec):4d} | {q(ack, 50):>7} {q(ack, 100):>6} "
                  f"{len(sel) - len(ack):4d} | {q(lat, 100):>11} {len(sel) - len(lat):4d} | {q(sta, 100):>10} "
                  f"{len(sel) - len(sta):4d}")
    rec = [r["recovery"] for r in rows if r["recovery"] is not None]
    ack = [r["ack"] for r in rows if r["ack"] is not None]
    print(f"reconnect_cycles={len(rows)} goals_lost={len(rows) - len(ack)} "
          f"latched_lost={sum(r['latched'] is None for r in rows)} stream_lost={len(rows) - len(rec)} "
          f"status_lost={sum(r['status'] is None for r in rows)} "
          f"recovery_p50_s={np.percentile(rec, 50) if rec else float('nan'):.2f} "
          f"recovery_p99_s={np.percentile(rec, 99) if rec else float('nan'):.2f} "
          f"ack_p99_s={np.percentile(ack, 99) if ack else float('nan'):.2f} hog_procs={args.hog} "
          f"peers_per_side={args.peers + 1} autoconnect={args.autoconnect} children={args.children}")
    return 0 if len(ack) == len(rows) and all(r["latched"] is not None and r["status"] is not None
                                              for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
