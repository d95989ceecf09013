"""The bus checks of ``zenav doctor``: the session and its endpoints, multicast scouting, per robot the
live nodes, topic rates, TF age and clock skew, costmap sensor reports, and a route to every node (its
``node_stats`` service answers). Each check is reported as a ``Check`` (PASS / WARN / FAIL / SKIP, with
the fix) through the caller's ``report``."""

from __future__ import annotations

import threading
import time
from collections import defaultdict
from typing import TYPE_CHECKING

from common.live_keys import LiveKey, live_key
from deploy.doctor.host_checks import Check, sensor_checks, skew_check

if TYPE_CHECKING:
    from common.messages import CostmapSensors

SCOUT_S = 1.5


class Listener:
    """Collects liveliness tokens, stamped samples of the expected topics (+ clock) and the costmaps'
    sensor status (``<costmap>/sensors``)."""

    def __init__(self, session, robot: str, topics: list[str]) -> None:
        import zenoh

        self.lock = threading.Lock()
        self.tokens: set[tuple[str, str, str, str]] = set()  # (robot, kind, node, name)
        self.samples: dict[tuple[str, str], list[float]] = defaultdict(list)  # monotonic receive times
        self.offsets: dict[str, list[float]] = defaultdict(list)  # robot -> receive wall - stamp
        self.tf: dict[str, tuple[float, float]] = {}  # robot -> (monotonic, stamp) of odom->base_link
        self.tf_edges: dict[str, set[str]] = defaultdict(set)
        self.sensors: dict[tuple[str, str], CostmapSensors] = {}  # (robot, costmap) -> latest CostmapSensors
        self.kind_put = zenoh.SampleKind.PUT
        self.ents = [session.liveliness().declare_subscriber(live_key(robot, "**", ""), self._on_token,
                                                             history=True)]
        for t in [*topics, "clock"]:
            self.ents.append(session.declare_subscriber(f"zenav/{robot}/{t}", self._on_sample))
        self.ents.append(session.declare_subscriber(f"zenav/{robot}/**/sensors", self._on_sensors))

    def _on_token(self, s) -> None:
        item = LiveKey.parse(s.key_expr)
        if item is not None:
            with self.lock:
                (self.tokens.add if s.kind == self.kind_put else self.tokens.discard)(item)

    def _on_sample(self, s) -> None:
        from common.codec import decode

        now_w, now_m = time.time(), time.monotonic()
        _, robot, topic = str(s.key_expr).split("/", 2)
        try:
            msg = decode(s.payload.to_bytes())
        except Exception:  # noqa: BLE001 - malformed or unknown type: counted as traffic only
            msg = None
        with self.lock:
            self.samples[(robot, topic)].append(now_m)
            stamps = []
            if hasattr(msg, "header"):
                stamps.append(msg.header.stamp)
            for tr in getattr(msg, "transforms", ()):
                parent, child = tr.header.frame_id.strip("/"), tr.child_frame_id.strip("/")
                self.tf_edges[robot].add(f"{parent}→{child}")
                stamps.append(tr.header.stamp)
                if (parent, child) == ("odom", "base_link"):
                    self.tf[robot] = (now_m, tr.header.stamp)
            if topic != "clock":
                self.offsets[robot] += [now_w - st for st in stamps if st > 0]

    def _on_sensors(self, s) -> None:
        from common.codec import decode
        from common.messages import CostmapSensors

        _, robot, topic = str(s.key_expr).split("/", 2)
        try:
            msg = decode(s.payload.to_bytes(), CostmapSensors)
        except Exception:  # noqa: BLE001 - another type on a '.../sensors' topic: not ours
            return
        with self.lock:
            self.sensors[(robot, msg.costmap or topic.removesuffix("/sensors"))] = msg

    def close(self) -> None:
        from common.bus import close_quietly

        close_quietly(*self.ents)


def session_checks(session, conf, desc: dict, report, wait_s: float) -> None:
    mc = f"on ({desc['multicast_address']})" if desc["multicast"] else "off"
    extra = f", user {desc['usrpwd_user']}" if desc["usrpwd_user"] else ""
    extra += ", access control on" if desc["access_control"] else ""
    report(Check("zenoh session opens", "PASS",
                 f"zid {session.zid()}, mode {desc['mode']}, listen {desc['listen'] or 'default'}, connect "
                 f"{desc['connect'] or 'none'}, multicast {mc}, lease {desc['lease_ms']} ms{extra}"))
    deadline = time.monotonic() + wait_s
    info = session.info
    while time.monotonic() < deadline and not (info.routers_zid() or info.peers_zid()):
        time.sleep(0.05)
    routers, peers = info.routers_zid(), info.peers_zid()
    if desc["mode"] == "client":
        ok = bool(routers)
        report(Check("router reached", "PASS" if ok else "FAIL",
                     f"{len(routers)} router(s)" if ok else f"no router at {desc['connect']}",
                     "start the router (`zenav zenoh router --config router.json5`), check the address and "
                     "port 7447 in the firewall,\nand the user / password if the router has usrpwd"))
    elif desc["connect"]:
        ok = bool(routers or peers)
        report(Check("configured endpoints reached", "PASS" if ok else "FAIL",
                     f"{len(peers)} peer(s), {len(routers)} router(s)" if ok else
                     f"nothing answered at {', '.join(desc['connect'])}",
                     "is zenav running there, listening on that endpoint (--listen tcp/0.0.0.0:7447)?\n"
                     "firewall: allow tcp 7447; with usrpwd a wrong password looks exactly like this"))


def scout_check(conf, own_zid: str, desc: dict, report) -> None:
    import zenoh

    if not desc["multicast"]:
        report(Check("multicast scouting", "SKIP", "disabled in the config (explicit endpoints)"))
        return
    found: dict[str, str] = {}
    try:
        scout = zenoh.scout(what="peer|router", config=conf)
    except Exception as e:  # noqa: BLE001 - no multicast route / socket error
        report(Check("multicast scouting", "FAIL", f"cannot scout: {e}",
                     "multicast is unusable here: add a route (`ip route add 224.0.0.0/4 dev <if>`) or use "
                     "--no-multicast --connect tcp/<robot>:7447"))
        return
    end = time.monotonic() + SCOUT_S
    while time.monotonic() < end:
        hello = scout.try_recv()
        if hello is None:
            time.sleep(0.05)
            continue
        if str(hello.zid) != own_zid:
            found[str(hello.zid)] = f"{hello.whatami} {','.join(str(x) for x in hello.locators)}"
    scout.stop()
    if found:
        report(Check("multicast scouting", "PASS", f"{len(found)} Zenoh process(es) answered: "
                     + "; ".join(list(found.values())[:4])))
    else:
        report(Check("multicast scouting", "FAIL",
                     f"no answer on {desc['multicast_address']} within {SCOUT_S:.1f} s",
                     "nothing is running, or multicast seems blocked (Wi-Fi AP isolation, VPN, firewall on "
                     "udp 7446):\nuse --no-multicast --connect tcp/<robot-ip>:7447 here and --listen "
                     "tcp/0.0.0.0:7447 on the robot"))


def robot_checks(lis: Listener, robots: list[str], topics: list[str], window: float, args, report) -> None:
    with lis.lock:
        for r in robots:
            nodes = sorted(n for rr, k, n, _ in lis.tokens if rr == r and k == "node")
            pubs = defaultdict(set)
            for rr, k, n, name in lis.tokens:
                if rr == r and k == "pub":
                    pubs[name].add(n)
            report(Check(f"[{r}] nodes alive", "PASS", f"{len(nodes)}: {' '.join(nodes)}"))
            for t in topics:
                ts = lis.samples.get((r, t), [])
                if len(ts) >= 2:
                    hz = (len(ts) - 1) / max(ts[-1] - ts[0], 1e-6)
                    report(Check(f"[{r}] topic {t}", "PASS", f"{hz:.1f} Hz ({len(ts)} msgs, publisher "
                                 f"{','.join(sorted(pubs.get(t, ()))) or '?'})"))
                    continue
                who = sorted(pubs.get(t, ()))
                fix = (f"{','.join(who)} is alive but nothing arrived: is it publishing "
                       f"(`zenav topic hz {t}` on the robot)?\nacross containers/namespaces set ZENAV_SHM=0; "
                       "access control on the robot may drop it" if who else
                       f"nobody publishes zenav/{r}/{t}: start the node that does "
                       "(`zenav robot --config ...`)\nor check the robot name (--robot / ZENAV_ROBOT)")
                report(Check(f"[{r}] topic {t}", "FAIL", f"{len(ts)} message(s) in {window:.1f} s", fix))
            if "tf" in topics:
                got = lis.tf.get(r)
                age = time.monotonic() - got[0] if got else float("inf")
                if age <= args.tf_max_age:
                    report(Check(f"[{r}] TF odom→base_link fresh", "PASS", f"last {age * 1e3:.0f} ms ago"))
                else:
                    edges = ", ".join(sorted(lis.tf_edges.get(r, ()))) or "none"
                    report(Check(f"[{r}] TF odom→base_link fresh", "FAIL",
                                 "never received" if got is None else f"last {age:.1f} s ago",
                                 f"the base driver publishes odom→base_link (edges seen: {edges});\n"
                                 "check the base node is running and its publish_tf / frame names"))
            sim = len(lis.samples.get((r, "clock"), [])) > 0
            check = skew_check(lis.offsets.get(r, []), args.max_skew, sim)
            check.name = f"[{r}] {check.name}"
            report(check)
            for c in sensor_checks(r, {cm: msg for (rr, cm), msg in lis.sensors.items() if rr == r}, pubs):
                report(c)


def route_checks(session, robot: str, nodes: list[str], report, timeout: float = 3.0) -> None:
    """Ask every live node of ``robot`` for its node_stats at once; a node that does not answer is named."""
    import zenoh

    answered: set[str] = set()
    done = threading.Event()
    left = [len(nodes)]
    lock = threading.Lock()

    def handler(name: str):
        def on_reply(reply) -> None:
            if reply.ok is not None or not reply.err.payload.to_string().lower().startswith("timeout"):
                with lock:  # an error reply is an answer too: the route works
                    answered.add(name)

        def on_done() -> None:
            with lock:
                left[0] -= 1
                if left[0] == 0:
                    done.set()
        return zenoh.handlers.Callback(on_reply, on_done)

    from common.codec import encode
    from common.messages import Empty

    for n in nodes:
        session.get(f"zenav/{robot}/srv/node_stats/{n}", handler(n), payload=encode(Empty()), timeout=timeout)
    done.wait(timeout + 2.0)
    missing = sorted(set(nodes) - answered)
    if not missing:
        report(Check(f"[{robot}] routes to its nodes", "PASS", f"{len(nodes)} of {len(nodes)} answer a query"))
    else:
        report(Check(f"[{robot}] routes to its nodes", "FAIL",
                     f"{', '.join(missing)} alive (token seen) but no answer within {timeout:.0f} s",
                     "a missing route: commands to it (goals, cancels) would not be acknowledged;\n"
                     "a node that is busy or hung also shows here (`zenav nodes --stats`); after a network "
                     "change, restarting the node re-forms its routes"))
