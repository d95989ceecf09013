"""Hostile bus input against every node type, each in its own process, started by the real agents.

Three robots, each with its own key prefix: (A) the simulated Pioneer with its Kinect scan, the
known-map master and AMCL; (B) the simulated Pioneer with the virtual-scan pipeline and the SLAM master;
(C) the P2OS driver on a fake robot behind a pty. Every node answers ``node_stats/<node>``: its
subscriptions and their counters. For every subscribed topic, ``hostile.payloads`` are published
raw (no encoder in the way); then every subscriber must have counted each payload where it belongs —
malformed, invalid or received — no callback may have raised, no process may have died or been
restarted, and the topics that carried traffic before still carry it.

Used by ``tests/bus/test_fuzz_nodes.py`` and ``bench/fuzz.py``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import yaml
import zenoh

from common.bus import Node, list_live
from common.messages import REGISTRY, Empty, NodeStats
from testkit.hostile import payloads

REPO = Path(__file__).resolve().parents[1]
ROBOT_CFG, MASTER_CFG = REPO / "robot_side" / "config", REPO / "master_side" / "config"
PY = sys.executable
ZENAV = [PY, "-m", "deploy.cli"]


@dataclass
class Group:
    name: str
    commands: list[list[str]]  # argv of each process ({tmp} is filled in)
    nodes: set[str]  # the nodes that must be up
    sim_time: bool = True
    robot: str = ""
    procs: list[subprocess.Popen] = field(default_factory=list)


def groups() -> list[Group]:
    amcl = [PY, "-m", "master_side.localization.amcl_node", "--config", str(MASTER_CFG / "p3at_amcl.yaml"),
            "--section", "nodes.localization.params", "--name", "amcl"]
    return [
        Group("A", [[*ZENAV, "robot", "--config", str(ROBOT_CFG / "p3at_sim.yaml")],
                    [*ZENAV, "master", "--config", str(MASTER_CFG / "p3at_known_map.yaml")], amcl],
              {"sim", "depth_to_scan", "collision_monitor", "localization", "map_server", "global_costmap",
               "local_costmap", "move_base", "amcl"}),
        Group("B", [[*ZENAV, "robot", "--config", str(ROBOT_CFG / "p3at_sim_virtual.yaml")],
                    [*ZENAV, "master", "--config", str(MASTER_CFG / "p3at_slam.yaml")]],
              {"sim", "cloud", "virtualizer", "merger", "collision_monitor", "slam_gmapping", "global_costmap",
               "local_costmap", "move_base"}),
        Group("C", [[PY, "-m", "robot_side.p2os.fake_robot", "--pty", "{tmp}/ttyFAKE"],
                    [*ZENAV, "robot", "--config", "{tmp}/p3at_real_fake.yaml"]], {"p2os_driver", "collision_monitor"},
              sim_time=False),
    ]


def _real_robot_config(tmp: Path) -> None:
    data = yaml.safe_load((ROBOT_CFG / "p3at_real.yaml").read_text())
    data["platform"]["p2os_driver"]["params"]["port"] = str(tmp / "ttyFAKE")
    (tmp / "p3at_real_fake.yaml").write_text(yaml.safe_dump(data))


LOST_FRACTION = 0.01  # payloads allowed to go missing on the way (seen only on a loaded 2-core machine)
QUIET_S = 15.0  # counters unchanged this long: nothing more is on its way


@dataclass
class Row:
    group: str
    node: str
    topic: str
    msg_type: str
    sent: int
    expected: dict  # label -> count sent
    got: dict  # counter -> delta (received, malformed, invalid, errors)

    @property
    def lost(self) -> int:
        """Payloads that never reached the node (a loaded machine's transport; not a counting error)."""
        e, g = self.expected, self.got
        return max(0, e["malformed"] - g["malformed"]) + max(0, e["invalid"] - g["invalid"]) + max(
            0, e["valid"] - g["received"])

    @property
    def ok(self) -> bool:
        """Nothing counted in the wrong place (a kind never over its count sent), no callback raised, and
        at most LOST_FRACTION of the payloads missing."""
        e, g = self.expected, self.got
        return (g["malformed"] <= e["malformed"] and g["invalid"] <= e["invalid"] and g["errors"] == 0
                and self.lost <= LOST_FRACTION * self.sent)


def _key(t) -> tuple[str, str]:
    return t.topic, t.msg_type


def _stats(node: Node, names: list[str], missed: dict[str, list[str]] | None = None) -> dict[str, NodeStats]:
    """Each node's answer; a node that does not answer is left out (reported by the caller), and why it did
    not goes into ``missed``: no queryable reached (ServiceUnavailable) or no answer in time (ServiceTimeout)."""
    out = {}
    for n in names:
        try:
            out[n] = node.call(f"node_stats/{n}", Empty(), NodeStats, timeout=5.0)
        except Exception as e:  # noqa: BLE001 - any failure is a miss, named below
            if missed is not None:
                missed.setdefault(n, []).append(type(e).__name__)
    return out


def _stats_of_all(node: Node, names: list[str], timeout: float, what: str,
                  strict: bool = True) -> dict[str, NodeStats]:
    """Every node's answer, a node left unanswered asked again until ``timeout`` as the bus's own callers do
    (common/delivery.py): a query that reaches no queryable asks its owner to declare it again, and the next
    call finds it. On a loaded machine move_base once missed the baseline's call (a fresh-clone run,
    2026-11-30), and the check after the fuzz, finding a pid it had not recorded, reported it as restarted
    ("pid None -> 6102"). A node that answers only when asked again is printed with why it missed (its
    queryable not reached, or slow), so such a run says which. ``strict=False``: the nodes that answered,
    the others left out for the caller to report (each silent one is printed with its misses)."""
    out: dict[str, NodeStats] = {}
    missed: dict[str, list[str]] = {}

    def answered() -> bool:
        out.update(_stats(node, [n for n in names if n not in out], missed))
        return len(out) == len(names)
    try:
        _wait(answered, timeout, f"{what}: every node's node_stats", None)
    except AssertionError as e:
        left = sorted(set(names) - set(out))
        if strict:
            raise AssertionError(f"{e} ({', '.join(f'{n}: {missed.get(n)}' for n in left)} did not answer)") from None
    for n, why in missed.items():
        did = f"answered node_stats after {len(why)} miss(es)" if n in out else f"did not answer in {len(why)} calls"
        print(f"{what}: {n} {did}: {', '.join(why)}", file=sys.stderr)
    return out


def _counts(stats: dict[str, NodeStats]) -> dict[tuple[str, int, str, str], dict]:
    """(node, row index, topic, type) -> counters (a node may subscribe one topic twice)."""
    return {(n, i, t.topic, t.msg_type): {"received": t.received, "malformed": t.malformed,
                                          "invalid": t.invalid, "errors": t.errors}
            for n, s in stats.items() for i, t in enumerate(s.topics)}


def _wait(cond, timeout: float, what: str, log, period: float = 0.2) -> None:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout:.0f} s: {what}")
        time.sleep(period)


def _start(g: Group, tmp: Path, env: dict) -> None:
    g.robot = f"fz{g.name.lower()}{uuid.uuid4().hex[:6]}"
    genv = {**env, "ZENAV_ROBOT": g.robot, "ZENAV_USE_SIM_TIME": "1" if g.sim_time else "0"}
    for i, argv in enumerate(g.commands):
        argv = [a.format(tmp=tmp, robot=g.robot) for a in argv]
        if "robot" in argv or "master" in argv:
            argv += ["--robot", g.robot]
        out = open(tmp / f"{g.name}{i}.log", "w")  # noqa: SIM115 - the child owns it
        g.procs.append(subprocess.Popen(argv, env=genv, stdout=out, stderr=subprocess.STDOUT, cwd=REPO,
                                        start_new_session=True))
        if "fake_robot" in " ".join(argv):
            _wait(lambda: (tmp / "ttyFAKE").exists(), 30, "the fake P2OS pty", None)


def _stop(g: Group) -> None:
    for p in g.procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
    for p in reversed(g.procs):
        try:
            p.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)


def run(per_topic: int, tmp: Path, log=print, expect_nodes: int = 0) -> tuple[list[Row], list[str]]:
    """Fuzz every subscribed topic of every node with ``per_topic`` payloads. Returns the rows and the
    problems found (dead / restarted processes, silent nodes, topics that stopped)."""
    tmp.mkdir(parents=True, exist_ok=True)
    _real_robot_config(tmp)
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1")
    gs = groups()
    rows: list[Row] = []
    problems: list[str] = []
    for g in gs:  # one group at a time: on two cores, thirty busy processes starve each other
        t0 = time.monotonic()
        try:
            _start(g, tmp, env)
            rows += _fuzz_group(g, per_topic, log, problems, env, t0)
            dead = [" ".join(p.args[-4:]) for p in g.procs if p.poll() is not None]
            problems += [f"group {g.name}: process ended: {d}" for d in dead]
        finally:
            t1 = time.monotonic()
            _stop(g)
            log(f"group {g.name}: stopped in {time.monotonic() - t1:.1f} s")
        log(f"group {g.name}: done in {time.monotonic() - t0:.0f} s")
    return rows, problems


def _nodes(node: Node, robot: str) -> list[str]:
    return sorted({k.rsplit("/", 1)[-1] for k in list_live(node.session, robot, "node")} - {"fuzzer"})


def _fuzz_group(g: Group, per_topic: int, log, problems: list[str], env: dict, tstart: float = 0.0) -> list[Row]:
    with Node("fuzzer", robot=g.robot, use_sim_time=False) as node:
        def up():
            names = _nodes(node, g.robot)
            return g.nodes <= set(names) and len(_stats(node, names)) == len(names)
        try:
            _wait(up, 240, f"group {g.name}: nodes {sorted(g.nodes)} up", log)
        except AssertionError as e:
            problems.append(f"{e}; up: {_nodes(node, g.robot)}")
            return []
        names = _nodes(node, g.robot)
        log(f"group {g.name}: up after {time.monotonic() - tstart:.1f} s")
        try:
            before = _stats_of_all(node, names, 120, f"group {g.name}: before the fuzz")
            time.sleep(2.0)
            before2 = _stats_of_all(node, names, 120, f"group {g.name}: before the fuzz")
        except AssertionError as e:
            problems.append(str(e))
            return []
        c0, c1 = _counts(before), _counts(before2)
        # topics with steady traffic (a latched map arrives once): they must still flow after the fuzz
        live = {k for k in c1 if k in c0 and c1[k]["received"] >= c0[k]["received"] + 3}
        pids = {n: s.pid for n, s in before2.items()}
        now = max(s.header.stamp for s in before2.values())
        topics: dict[str, str] = {}
        for s in before2.values():
            for t in s.topics:
                for topic in (("tf", "tf_static") if t.topic == "tf+tf_static" else (t.topic,)):
                    topics[topic] = t.msg_type
        log(f"group {g.name} (robot {g.robot}): {len(names)} nodes, {len(topics)} subscribed topics")
        sent: dict[str, dict] = {}

        def expected(topic: str) -> dict:  # sent so far to a subscription's topic (tf+tf_static: both)
            parts = [sent.get(t, {}) for t in (("tf", "tf_static") if topic == "tf+tf_static" else (topic,))]
            return {k: sum(p.get(k, 0) for p in parts) for k in ("valid", "invalid", "malformed")}

        def deltas(only: list[str] | None = None):
            c2 = _counts(_stats(node, only if only is not None else names))
            return {k: {m: c2[k][m] - c1[k][m] for m in c1[k]} for k in c1 if k in c2}

        def counted(keys) -> bool:
            d = deltas(sorted({k[0] for k in keys}))
            return all(k in d and d[k]["malformed"] + d[k]["invalid"] >= expected(k[2])["malformed"]
                       + expected(k[2])["invalid"] and d[k]["received"] >= expected(k[2])["valid"] for k in keys)

        def all_counted():
            return counted(list(c1))
        t0 = time.monotonic()
        slow: list[str] = []
        for topic, kind in sorted(topics.items()):
            cls = REGISTRY[kind].cls if kind != "*" else None
            data, labels = payloads(cls, per_topic, now, seed=zlib.crc32(topic.encode()))
            pub = node.session.declare_publisher(node.key(topic), congestion_control=zenoh.CongestionControl.BLOCK)
            for b in data:
                pub.put(b)
            pub.undeclare()
            sent[topic] = labels
            # One topic in flight at a time: the next burst waits until every subscriber of this one counted
            # it, so a node busy elsewhere (slam_gmapping in a scan update) never has every topic's payloads
            # queued towards it at once. A blocked reliable publisher makes Zenoh close the link after a
            # while and drop what was queued; that is the likely cause of a loaded run in which slam_gmapping
            # counted 17 % of the tf+tf_static payloads while the simulator's TF kept arriving.
            # Not counted in time: go on; the final count below says what is short.
            keys = [k for k in c1 if k[2] == topic or (k[2] == "tf+tf_static" and topic in ("tf", "tf_static"))]
            try:
                _wait(lambda keys=keys: counted(keys), 60, f"'{topic}' counted", log, period=0.02)
            except AssertionError:
                slow.append(topic)
        log(f"group {g.name}: {per_topic * len(topics)} payloads published in {time.monotonic() - t0:.1f} s"
            + (f" (not counted within 60 s of their burst: {slow})" if slow else ""))
        quiet = {"counts": None, "since": time.monotonic()}

        def settled():  # every payload counted, or the counters stopped moving (the rows then say what is short)
            if all_counted():
                return True
            c = {k: (v["malformed"], v["invalid"]) for k, v in _counts(_stats(node, names)).items()}  # live
            if c != quiet["counts"]:  # topics keep 'received' moving
                quiet.update(counts=c, since=time.monotonic())
            return time.monotonic() - quiet["since"] > QUIET_S
        try:
            _wait(settled, 300, f"group {g.name}: every payload counted", log)
        except AssertionError as e:
            problems.append(str(e))
        log(f"group {g.name}: {'every payload' if all_counted() else 'not every payload'} counted "
            f"{time.monotonic() - t0:.1f} s after the first")
        time.sleep(0.5)
        d = deltas()
        # asked as the baseline was: one missed call on a loaded machine is not a node that stopped answering
        after = _stats_of_all(node, names, 120, f"group {g.name}: after the fuzz", strict=False)
        for n in names:
            if n not in after:
                problems.append(f"group {g.name}: node {n} no longer answers")
            elif after[n].pid != pids.get(n):
                problems.append(f"group {g.name}: node {n} restarted (pid {pids.get(n)} -> {after[n].pid})")
        c3 = _counts(after)
        still = set()
        end = time.monotonic() + 10.0
        while time.monotonic() < end and still != live:
            time.sleep(0.5)
            c4 = _counts(_stats(node, names))
            still |= {k for k in live if k in c4 and c4[k]["received"] > c3[k]["received"]}
        problems += [f"group {g.name}: {k[0]} no longer receives '{k[2]}'" for k in sorted(live - still)]
        return [Row(g.name, k[0], k[2], k[3], sum(expected(k[2]).values()), expected(k[2]), v)
                for k, v in sorted(d.items())]
