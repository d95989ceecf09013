"""``zenav zenoh config peer|client|router ...`` and ``zenav zenoh router --config F`` — Zenoh configs
for two machines (auth, access control, TLS) and a Zenoh router in Python (deploy.zenohconf)."""

from __future__ import annotations

import json
import os
import re
import signal
import sys
import threading

from common.argtypes import positive, positive_int
from common.tcp_linger import open_session
from deploy import zenohconf


def add_parser(subparsers):
    p = subparsers.add_parser(
        "zenoh", help="generate Zenoh configs (auth, access control, TLS); run a router",
        description="Zenoh configuration for two machines. The generated json5 is used with "
        "ZENAV_ZENOH_CONFIG=<file> (put it in /etc/zenav/zenav.env with the ZENAV_MODE line printed).")
    sp = p.add_subparsers(dest="zenoh_cmd", metavar="SUBCOMMAND", required=True)
    c = sp.add_parser(
        "config", help="write a Zenoh config file for one role",
        description="peer: robot / master on one LAN (multicast). client: reaches the others through a "
        "router. router: the hub (zenav zenoh router). On the robot, --acl-cmd-vel-only master lets only "
        "the authenticated user 'master' publish zenav/*/cmd_vel (others' puts are silently dropped).",
        epilog="examples:\n"
        "  robot:  zenav zenoh config peer --listen tcp/0.0.0.0:7447 --user robot --password-file rpw "
        "--users-file users.txt --acl-cmd-vel-only master -o robot.json5\n"
        "  master: zenav zenoh config peer --connect tcp/<robot>:7447 --user master --password-file mpw "
        "-o master.json5\n"
        "  router: zenav zenoh config router --listen tcp/0.0.0.0:7447 -o router.json5",
        formatter_class=__import__("argparse").RawDescriptionHelpFormatter)
    c.add_argument("role", choices=zenohconf.ROLES)
    c.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")
    c.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to connect to, e.g. tcp/10.0.0.2:7447 (repeatable)")
    c.add_argument("--no-multicast", action="store_true", help="disable multicast scouting")
    c.add_argument("--lease-ms", type=positive_int, default=1000, help="link lease (default 1000 ms: a lost "
                   "machine is noticed in about a second)")
    c.add_argument("--user", default="", help="usrpwd user this side authenticates as")
    c.add_argument("--password-file", default="", metavar="F", help="file holding --user's password")
    c.add_argument("--users-file", default="", metavar="F",
                   help="usrpwd dictionary (lines user:password) checked when others connect here")
    c.add_argument("--acl-cmd-vel-only", default="", metavar="USER",
                   help="only USER (usrpwd name or certificate CN) may publish zenav/*/cmd_vel here")
    c.add_argument("--tls-ca", default="", metavar="PEM", help="CA certificate (tls/ endpoints)")
    c.add_argument("--tls-cert", default="", metavar="PEM", help="this side's certificate")
    c.add_argument("--tls-key", default="", metavar="KEY", help="this side's private key")
    c.add_argument("--mtls", action="store_true", help="mutual TLS (both sides present certificates)")
    c.add_argument("--no-shm", action="store_true", help="disable shared memory (containers, netns)")
    c.add_argument("-o", "--output", default="-", metavar="FILE", help="output file (default stdout)")
    c.set_defaults(func=run_config)
    r = sp.add_parser("router", help="run a Zenoh router in this process",
                      description="A Zenoh router (mode forced to router) from a config file, until Ctrl-C "
                      "/ SIGTERM. Prints 'router <zid> listening on ...' once up.")
    r.add_argument("--config", required=True, metavar="FILE", help="json5 from `zenav zenoh config router`")
    r.add_argument("--duration", type=positive, default=None, metavar="S", help="exit after S seconds")
    r.set_defaults(func=run_router)
    return p


def run_config(args) -> int:
    try:
        pw = zenohconf.read_password(args.password_file) if args.password_file else ""
        opts = zenohconf.Options(
            role=args.role, listen=args.listen, connect=args.connect,
            multicast=False if args.no_multicast else None, lease_ms=args.lease_ms, user=args.user,
            password=pw, users_file=_abs(args.users_file), acl_cmd_vel_only=args.acl_cmd_vel_only,
            tls_ca=_abs(args.tls_ca), tls_cert=_abs(args.tls_cert), tls_key=_abs(args.tls_key),
            mtls=args.mtls, shared_memory=False if args.no_shm else None)
        conf = zenohconf.build(opts)
        _validate(conf)
    except (zenohconf.ZenohConfError, OSError) as e:
        print(f"zenav zenoh config: {e}", file=sys.stderr)
        return 2
    argv = [a for a in sys.argv[sys.argv.index("config") + 1:]] if "config" in sys.argv else None
    text = zenohconf.render(conf, argv)
    if args.output == "-":
        sys.stdout.write(text)
    else:
        fd = os.open(args.output, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)  # may hold a password
        with os.fdopen(fd, "w") as f:
            f.write(text)
        print(f"wrote {args.output}; use: ZENAV_ZENOH_CONFIG={os.path.abspath(args.output)} "
              + " ".join(zenohconf.env_lines(conf)), file=sys.stderr)
    return 0


def _abs(path: str) -> str:
    return os.path.abspath(path) if path else ""


def _validate(conf: dict) -> None:
    """Zenoh itself parses the result (wrong keys / values fail here, not on the robot)."""
    import zenoh

    try:
        zenoh.Config.from_json5(json.dumps(conf))
    except Exception as e:  # noqa: BLE001 - zenoh raises ZError / ValueError
        raise zenohconf.ZenohConfError(f"zenoh rejects the generated config: {e}") from e


def _plain(e: Exception) -> str:
    """Zenoh's error without the Rust source location it appends (`... at .../lib.rs:1486.`)."""
    return re.sub(r"\s+at \S+\.rs:\d+\.?\s*$", "", str(e)).strip()


def run_router(args) -> int:
    import zenoh

    if not os.path.isfile(args.config):
        print(f"zenav zenoh router: {args.config}: no such file", file=sys.stderr)
        return 2
    try:
        conf = zenoh.Config.from_file(args.config)
    except Exception as e:  # noqa: BLE001 - zenoh raises ZError with the parser's message
        print(f"zenav zenoh router: {args.config}: not a valid Zenoh config: {_plain(e)}", file=sys.stderr)
        return 2
    try:
        conf.insert_json5("mode", '"router"')
        session = open_session(conf)
    except Exception as e:  # noqa: BLE001 - report bind errors plainly
        print(f"zenav zenoh router: cannot start with {args.config}: {_plain(e)}", file=sys.stderr)
        return 1
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    listen = json.loads(conf.get_json("listen/endpoints") or "[]")
    print(f"router {session.zid()} listening on {listen}", flush=True)
    try:
        stop.wait(args.duration)
    except KeyboardInterrupt:
        pass
    finally:
        session.close()
    return 0
