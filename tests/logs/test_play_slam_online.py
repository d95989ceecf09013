"""Issue 12 acceptance: online SLAM over the bus matches offline SLAM on the same scans.

`zenav master --config master_side/config/slam_datasets.yaml` (slam_gmapping on the log's clock) and
`zenav play aces.orig.bag --start S --duration D --rate R --trajectory OUT` run as processes on a private
loopback bus; the online trajectory's Kümmerle translational error over the relations inside the slice
is within 10 % of `master_side.slam.offline`'s on the same scans (computed here while the log plays).
The slice (the log's first 100 s: 612 scans, 106 relations; it was 100-250 s, 952 scans, 118 relations, 30 s
of playback, until the suite's time asked for less) costs a few seconds of one core offline. The node
queues what it cannot process at once (scan_queue_size 250 in the config, about 40 s of this log) and
works it off after the log ends. Rate 10 (15 s of playback of the earlier slice) was
not enough with the full suite on the other worker: 68 of 952 scans were dropped once (the node got about a
third of a core). Rate 5 (20 s of playback, 31 scans/s) left it about 6x headroom on a free core, yet a
rehearsal of 2026-11-28 dropped 12 of 612 (the node took under 18 scans/s with the suite beside it). Rate 3
(33 s of playback, 18 scans/s) needs 11 scans/s to keep up; a longer queue alone would not do: a scan that
waited longer than the node's 60 s of TF history is refused by the filter instead.

Every scan must reach the node, except while a link on its path was down. A process that gets no CPU for
longer than the link lease (1 s, ``common.zenoh_config``) has its link closed by the other side, and what was
on its way is lost: Zenoh's blocking congestion control does not outlive the link (measured: the SLAM node
stopped with SIGSTOP for 2 s lost 36 of 612 scans with the 1 s lease, none with a 10 s lease). That is the
bus's design (a frozen node must not hold the agent's routes, ``Node.publisher``), and a loaded CI run once
lost 8 scans this way. The test watches the nodes' liveliness tokens while the log plays: a token that
vanishes is such an outage, and each run of missing scans must lie in one. A scan the node's own bounded
queue dropped (the node starved of CPU for longer than its queue lasts: 24 of 612 once, 2026-11-30, with the
suite's heaviest tests beside it) is counted by the node (``node_stats``, `zenav nodes --stats`), and every
missing scan must be one of those or lie in an outage. Keeping up is a speed figure (`bench/slam.py`), not
this test's: here the offline filter then runs on the scans the node received, and must agree with it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from common.bus import Node, ServiceError
from common.live_keys import LiveKey, live_key
from common.zenoh_config import BusConfig
from deploy.stack.process_group import checkout_env
from deploy.stack.slam_counters import scan_row
from master_side.slam import evaluate
from master_side.slam.gridslam import GridSlam
from master_side.slam.logs import read_bag
from master_side.slam.offline import full_trajectory
from master_side.slam.params import load_gmapping
from tests.support import free_port

REPO = Path(__file__).resolve().parents[2]
START_S, SLICE_S, RATE = 0.0, 100.0, 3.0
TOLERANCE = 0.10  # online error within 10 % of offline


def offline_slice(bag: Path, begin: float, end: float, only: np.ndarray | None = None):
    """Offline SLAM (as `zenav slam run`) over the scans the online node can use: those in [begin, end]
    with odometry on both sides inside the window (the player sends no TF from outside it); ``only``: of
    those, the scans at these stamps."""
    from deploy.logs.readers import open_log

    it, _ = open_log(bag)
    odom_t = [r.stamp for r in it if r.topic == "odom" and begin <= r.stamp <= end]
    recs = [r for r in read_bag(bag) if odom_t[0] <= r.stamp <= odom_t[-1]]
    if only is not None:
        keep = {round(float(t), 6) for t in only}
        recs = [r for r in recs if round(r.stamp, 6) in keep]
    params = load_gmapping(str(REPO / "master_side/config/gmapping_datasets.yaml"), "")
    slam = GridSlam(params, track_between=True)
    for r in recs:
        slam.process(r.stamp, r.odom, r.scan)
    return np.array([r.stamp for r in recs]), full_trajectory([r.odom for r in recs], slam.trajectory(),
                                                              slam.between)


def _gaps(stamps: np.ndarray, received: np.ndarray) -> int:
    """How many runs of consecutive scans of ``stamps`` are missing from ``received``."""
    have = np.isin(np.round(stamps, 6), np.round(received, 6))
    return int(np.sum(~have[1:] & have[:-1]) + (not have[0]))


def _watch_nodes(port: int, robot: str) -> tuple[Node, list[tuple[str, bool]]]:
    """An observer on the master's endpoint; the list collects the nodes' liveliness changes, (node, alive).
    Its own lease is Zenoh's 10 s, so a starved test process does not close its link."""
    import zenoh

    node = Node("outage_watch", config=BusConfig(robot=robot, connect=(f"tcp/127.0.0.1:{port}",),
                                                 multicast=False, lease_ms=10000), use_sim_time=False)
    events: list[tuple[str, bool]] = []

    def on_token(sample: zenoh.Sample) -> None:
        if (k := LiveKey.parse(sample.key_expr)) is not None:
            events.append((k.node, sample.kind == zenoh.SampleKind.PUT))

    node.session.liveliness().declare_subscriber(live_key(robot, "node"), on_token, history=True)
    return node, events


def _outages(events: list[tuple[str, bool]]) -> list[str]:
    """Nodes whose token vanished and came back (a link closed and re-formed): one entry per outage. A node
    that ends (the player) loses its token for good and is not one."""
    out, gone = [], set()
    for name, alive in events:
        if not alive:
            gone.add(name)
        elif name in gone:
            gone.discard(name)
            out.append(name)
    return out


def _queue_drops(watch: Node) -> tuple[int | None, str]:
    """The SLAM node's scan queue drops from its ``node_stats`` service (what `zenav nodes --stats` prints),
    and the counters as text for the failure message; None when it does not answer."""
    try:
        scan = scan_row(watch)
    except ServiceError as e:  # a diagnosis: never hides the assertions after it
        return None, f"node_stats: {e}"
    return (scan.dropped if scan else None), f"node_stats: scan {scan}"


def _zenav(*args: str, robot: str, log: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "deploy.cli", *args, "--robot", robot, "--no-multicast"],
                            env=checkout_env(drop_zenav=True), cwd=REPO, stdout=log.open("w"),
                            stderr=subprocess.STDOUT, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)


@pytest.mark.slow
def test_online_slam_trajectory_error_is_within_10_percent_of_offline_on_an_aces_slice(shared_dir, robot_name,
                                                                                         tmp_path):
    bag = shared_dir / "datasets/slam/ros1_bags/aces.orig.bag"
    relations = evaluate.read_relations(shared_dir / "datasets/slam/aces.relations")
    port = free_port()
    out = tmp_path / "online.txt"
    master = _zenav("master", "--config", "master_side/config/slam_datasets.yaml", "--listen",
                    f"tcp/127.0.0.1:{port}", robot=robot_name, log=tmp_path / "master.log")
    watch, events = None, []
    try:
        watch, events = _watch_nodes(port, robot_name)
        t = time.monotonic()
        play = _zenav("play", str(bag), "--start", str(START_S), "--duration", str(SLICE_S), "--rate", str(RATE),
                      "--wait-for", "scan", "--wait-timeout", "120", "--trajectory", str(out), "--connect",
                      f"tcp/127.0.0.1:{port}", robot=robot_name, log=tmp_path / "play.log")
        from deploy.logs.readers import open_log

        begin = open_log(bag)[1].start + START_S
        off_t, off_p = offline_slice(bag, begin, begin + SLICE_S)  # on the other core, while the log plays
        try:
            rc = play.wait(timeout=300)
        finally:
            _stop(play)
        wall = time.monotonic() - t
        logs = "\n".join(f"{n}: {(tmp_path / f'{n}.log').read_text()[-1500:]}" for n in ("play", "master"))
        assert rc == 0, logs
        on_t, on_p = evaluate.read_trajectory(out)
        drops = 0
        if len(on_t) != len(off_t):  # say where the scans went: the node's counters, asked before it stops
            drops, text = _queue_drops(watch)
            logs += "\n" + text
    finally:
        if watch is not None:
            watch.close()
        _stop(master)
    outages = _outages(events)
    # every scan the node could use reached it and was processed, except those on their way while a link of
    # the path was down (a node's token vanished): each run of missing scans needs its own outage
    missing = len(off_t) - len(on_t)
    why = (len(on_t), len(off_t), f"link outages (nodes whose token vanished and came back): {outages}", logs)
    assert np.isin(np.round(on_t, 6), np.round(off_t, 6)).all(), why  # the node's scans are the log's
    if missing:
        dropped = drops or 0  # by the node's bounded queue, counted (None: its counters not read)
        assert dropped <= missing, why
        if missing > dropped:  # the rest lost on their way while a link was down: each run of them in an outage
            assert _gaps(off_t, on_t) <= len(outages) + (1 if dropped else 0), why
        print(f"{missing} scans missing: {dropped} dropped by the node's queue, the rest in "
              f"{_gaps(off_t, on_t)} run(s) with link outages {outages}; offline SLAM runs on the scans the node "
              "received")
        off_t, off_p = offline_slice(bag, begin, begin + SLICE_S, only=on_t)
    assert np.allclose(on_t, off_t, atol=1e-6), why
    online, offline = evaluate.evaluate(on_t, on_p, relations), evaluate.evaluate(off_t, off_p, relations)
    on_m, off_m = online.summary()["trans_mean_m"], offline.summary()["trans_mean_m"]
    print(f"slice {START_S:g}+{SLICE_S:g} s at rate {RATE:g}: online {on_m:.4f} m, offline {off_m:.4f} m over "
          f"{len(online.trans)} relations, {len(on_t)} scans, wall {wall:.1f} s")
    # 106 relations in the slice; a run of lost scans takes those with an end in it (93 after a 2 s outage)
    assert len(online.trans) == len(offline.trans) >= (100 if not missing else 60)
    assert abs(on_m - off_m) <= TOLERANCE * off_m, (on_m, off_m)
