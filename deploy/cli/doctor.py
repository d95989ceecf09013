"""``zenav doctor`` — can this machine talk to the robot? A PASS/FAIL list with the fix for each failure.

Checks, in order: the Zenoh session opens with the effective config (mode, endpoints, multicast,
lease); configured endpoints / routers are reached; multicast scouting finds other Zenoh processes;
zenav nodes alive per robot (liveliness); expected topics flow (rates); TF odom→base_link is fresh;
clock skew between this machine and the robot's header stamps; every live node answers a query from
here (its ``node_stats`` service: a node whose token arrives but whose queries do not has a missing
route — goals to it would not be acknowledged); every costmap observation source
delivers (``<costmap>/sensors``: a late or silent source fails, naming its topic); optionally the
serial port (on the robot). Exit 0 only if every check passes (SKIP counts as passed).
"""

from __future__ import annotations

import os
import sys
import time

from common.argtypes import positive
from common.tcp_linger import open_session
from deploy.cli.session import robot_pattern
from deploy.doctor.bus_checks import Listener, robot_checks, route_checks, scout_check, session_checks
from deploy.doctor.host_checks import OK_STATES, Check, describe_config, serial_check


def add_parser(subparsers):
    p = subparsers.add_parser(
        "doctor", help="check connectivity to the robot: PASS/FAIL with fixes",
        description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("--expect-topics", default="scan,odom,tf", metavar="T1,T2",
                   help="topics that must be flowing (default scan,odom,tf; '' = none)")
    p.add_argument("--timeout", type=positive, default=5.0, metavar="S",
                   help="how long to listen for nodes and topics (default 5 s)")
    p.add_argument("--serial", default="", metavar="DEV", help="on the robot: check this serial port "
                   "(e.g. /dev/pioneer) exists and is read/writable")
    p.add_argument("--max-skew", type=positive, default=0.05, metavar="S",
                   help="clock offset above which to warn (default 0.05 s)")
    p.add_argument("--tf-max-age", type=positive, default=1.0, metavar="S",
                   help="odom→base_link must have arrived within S s (default 1)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from common.bus import close_quietly
    from common.zenoh_config import BusConfig

    results: list[Check] = []

    def report(c: Check) -> None:

        results.append(c)
        print("\n".join(c.lines()), flush=True)

    robot = robot_pattern(args, all_by_default=True)
    topics = [t.strip().strip("/") for t in args.expect_topics.split(",") if t.strip()]
    env = dict(os.environ)
    if "*" in env.get("ZENAV_ROBOT", ""):
        env.pop("ZENAV_ROBOT")
    print(f"zenav doctor: robot {robot!r}, expecting {','.join(topics) or 'no topics'}", flush=True)
    session = lis = None
    try:
        try:
            conf = BusConfig.from_env(env).to_zenoh()
            desc = describe_config(conf)
            session = open_session(conf)
        except Exception as e:  # noqa: BLE001 - bad file, bad endpoint, refused credentials
            report(Check("zenoh session opens", "FAIL", f"{type(e).__name__}: {e}",
                         f"check ZENAV_ZENOH_CONFIG={env.get('ZENAV_ZENOH_CONFIG') or '(unset)'} "
                         "(`zenav zenoh config ...` writes a valid one),\n--connect endpoints, and for "
                         "a client the router address and user / password"))
            return _summary(results)
        t0 = time.monotonic()
        lis = Listener(session, robot, topics)
        session_checks(session, conf, desc, report, min(3.0, args.timeout))
        scout_check(conf, str(session.zid()), desc, report)
        deadline = t0 + args.timeout
        while time.monotonic() < deadline:
            time.sleep(0.05)
        with lis.lock:
            robots = sorted({r for r, k, _, _ in lis.tokens if k == "node"})
        if not robots:
            report(Check("zenav nodes alive", "FAIL", f"no node tokens zenavlive/{robot}/node/* within "
                         f"{args.timeout:.0f} s", "start the robot (`zenav robot --config ...` or "
                         "`systemctl start zenav-robot` on the robot PC);\nif it runs: same robot name "
                         "(ZENAV_ROBOT)? are the machines connected (checks above)?"))
            for t in topics:
                report(Check(f"topic {t}", "FAIL", "no robot", "see 'zenav nodes alive'"))
        else:
            robot_checks(lis, robots, topics, time.monotonic() - t0, args, report)
            with lis.lock:
                live = {r: sorted(n for rr, k, n, _ in lis.tokens if rr == r and k == "node") for r in robots}
            for r in robots:
                route_checks(session, r, live[r], report)
    finally:
        close_quietly(lis, session)
    if args.serial:
        report(serial_check(args.serial))
    return _summary(results)


def _summary(results: list[Check]) -> int:
    bad = [c for c in results if c.status not in OK_STATES]
    print(f"zenav doctor: {len(results) - len(bad)} passed, {len(bad)} failed"
          + (f" ({', '.join(c.name for c in bad)})" if bad else ""), flush=True)
    return 0 if not bad else 1


if __name__ == "__main__":
    from deploy.cli import main

    sys.exit(main(["doctor", *sys.argv[1:]]))
