"""``zenav fleet install|up|down|restart|status|logs|upgrade|check`` — robots and masters from one
machine over SSH, from an inventory file (deploy/fleet, docs/fleet.md)."""

from __future__ import annotations

import argparse
import os
import sys

from common.argtypes import positive, positive_int

EPILOG = """\
inventory: --inventory FILE, else $ZENAV_FLEET, else ./fleet.yaml (example: deploy/hosts/fleet.example.yaml)
examples:
  zenav fleet check                      validate the inventory, log in to every host
  zenav fleet install --dry-run          every command and file, nothing done
  zenav fleet install && zenav fleet up
  zenav fleet status                     one table; each problem with its fix
  zenav fleet logs robot1 move_base -f
  zenav fleet upgrade                    rolling, one host at a time
"""


def add_parser(subparsers):
    p = subparsers.add_parser(
        "fleet", help="install, start, watch and upgrade robots and masters over SSH (fleet.yaml)",
        description=__doc__.replace("\n", " "), epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-i", "--inventory", default=os.environ.get("ZENAV_FLEET", "fleet.yaml"), metavar="FILE",
                   help="the inventory YAML (default $ZENAV_FLEET or ./fleet.yaml)")
    sp = p.add_subparsers(dest="fleet_cmd", metavar="SUBCOMMAND", required=True)

    def sub(name: str, help_: str, hosts: bool = True, dry: bool = True) -> argparse.ArgumentParser:
        s = sp.add_parser(name, help=help_, description=help_)
        if hosts:
            s.add_argument("hosts", nargs="*", metavar="HOST", help="hosts of the inventory (default: all)")
        if dry:
            s.add_argument("--dry-run", action="store_true", help="print every command, run none")
        s.set_defaults(func=run)
        return s

    sub("check", "validate the inventory and log in to each host over ssh", dry=False)
    s = sub("install", "copy this checkout to each host, venv + pip install, env / Zenoh config, "
                       "systemd unit or supervisor, udev rule on robots (idempotent)")
    s.add_argument("--serial", action="store_true", help="one host after the other (default: in parallel)")
    sub("up", "start the services (routers, robots, then masters)")
    sub("down", "stop the services (masters first)")
    sub("restart", "restart the services")
    s = sub("status", "per host: service, nodes (liveliness), topic rates, clock offset, last errors", dry=False)
    s.add_argument("--seconds", type=positive, default=2.0, help="how long each host listens (default 2)")
    s = sub("upgrade", "rolling upgrade: install + restart one host at a time, wait for its nodes")
    s.add_argument("--timeout", type=positive, default=90.0, metavar="S",
                   help="how long a host's nodes may take to come back (default 90 s)")
    s = sp.add_parser("logs", help="a host's service log (one node's lines with NODE)",
                      description="the service log of HOST (journalctl or the supervisor's log file)")
    s.add_argument("host", metavar="HOST")
    s.add_argument("node", nargs="?", default="", metavar="NODE")
    s.add_argument("-f", "--follow", action="store_true")
    s.add_argument("-n", "--lines", type=positive_int, default=100, help="how many lines (default 100)")
    s.set_defaults(func=run)
    return p


def run(args) -> int:
    from common.config_errors import ConfigError
    from deploy.fleet import FleetError, inventory

    try:
        inv = inventory.load(args.inventory)
        hosts = inv.select([args.host] if args.fleet_cmd == "logs" else args.hosts)
    except ConfigError as e:
        print(f"zenav fleet: invalid inventory:\n{e}", file=sys.stderr)
        return 2
    try:
        return _dispatch(args, inv, hosts)
    except FleetError as e:
        print(f"zenav fleet {args.fleet_cmd}: {e}", file=sys.stderr)
        return 1


def _dispatch(args, inv, hosts) -> int:
    from deploy.fleet import install, ops, status

    def echo(text: str) -> None:
        print(text, flush=True)

    cmd = args.fleet_cmd
    if cmd == "check":
        from deploy.fleet import FleetError
        from deploy.fleet.ssh import Remote

        bad = 0
        for h in hosts:
            try:
                echo(f"[{h.name}] ok: {install.check_host(Remote(h))} ({h.role}, robot {h.robot or '-'})")
            except FleetError as e:
                bad += 1
                echo(f"[{h.name}] FAILED: {e}")
        return 1 if bad else 0
    if cmd == "install":
        return 1 if install.install(inv, hosts, args.dry_run, echo, parallel=not args.serial) else 0
    if cmd in ("up", "down", "restart"):
        return 1 if getattr(ops, cmd)(inv, hosts, args.dry_run, echo) else 0
    if cmd == "status":
        _, text, bad = status.status(inv, hosts, args.seconds)
        echo(text)
        return 1 if bad else 0
    if cmd == "upgrade":
        return ops.upgrade(inv, hosts, args.timeout, args.dry_run, echo)
    if cmd == "logs":
        return ops.logs(hosts[0], args.node, args.lines, args.follow)
    raise AssertionError(cmd)


if __name__ == "__main__":
    from deploy.cli import main

    sys.exit(main(["fleet", *sys.argv[1:]]))
