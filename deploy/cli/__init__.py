"""The ``zenav`` command: one dispatcher, one module per subcommand.

To add a subcommand ``foo``: write ``deploy/cli/foo.py`` (argument parsing and printing only; the work
it does belongs to the part of ``deploy`` it concerns, or below) with

    def add_parser(subparsers) -> argparse.ArgumentParser:
        p = subparsers.add_parser("foo", help="...", description="...")
        p.add_argument(...)
        p.set_defaults(func=run)          # run(args) -> int exit status
        return p

and add ``"deploy.cli.foo"`` to ``COMMANDS`` below. The bus options (``--robot``, ``--connect``,
``--listen``, ``--mode``, ``--no-multicast``) are added to every subcommand automatically (they are
accepted before or after the subcommand) and exported as ``ZENAV_*`` environment variables, so
``common.zenoh_config.BusConfig.from_env()`` — in this process and in every child it starts — sees them.
A robot pattern containing ``*`` (``--robot '*'``) is kept in ``args.robot`` and not exported.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import sys

# One line per subcommand module (order = order in --help).
COMMANDS = [
    "deploy.cli.topic",
    "deploy.cli.nodes",
    "deploy.cli.tf",
    "deploy.cli.robot",
    "deploy.cli.master",
    "deploy.cli.monitor",
    "deploy.cli.goal",
    "deploy.cli.explore",
    "deploy.cli.demo",
    "deploy.cli.slam",
    "deploy.cli.play",
    "deploy.cli.record",
    "deploy.cli.map",
    "deploy.cli.zenoh",
    "deploy.cli.doctor",
    "deploy.cli.fleet",
]

EPILOG = """\
discovery:
  zenav needs no master. Every process opens a Zenoh session in PEER mode with MULTICAST
  SCOUTING (group 224.0.0.224:7446): machines on one LAN find each other with no address, no
  hosts file and no ROS_MASTER_URI. Topics are key expressions zenav/<robot>/<topic>; every
  node holds a liveliness token, so `zenav nodes` and `zenav topic list` see who is there and
  notice a lost machine within about a second (link lease 1000 ms, ZENAV_LEASE_MS).
  Without multicast (some Wi-Fi, VPNs, containers): --no-multicast --connect tcp/<host>:7447 on
  one side and --listen tcp/0.0.0.0:7447 on the other, or --mode client --connect <router>.
  With three peers or more, give each one every peer it needs in --connect: Zenoh dials a
  configured endpoint again after a link loss, but not a peer it only heard of by gossip.
  The options set ZENAV_ROBOT, ZENAV_CONNECT, ZENAV_LISTEN, ZENAV_MODE, ZENAV_MULTICAST for every
  process started from here; ZENAV_ZENOH_CONFIG=<file.json5> adds a full Zenoh config (auth, TLS).

examples:
  zenav topic list                    all topics of all robots, with type and publishers
  zenav --robot pioneer1 topic hz scan
  zenav topic echo odom -n 1 --robot pioneer1
  zenav nodes --watch                 print nodes appearing / disappearing
"""

BUS_OPTIONS = ("--robot", "--connect", "--listen", "--mode", "--no-multicast")


def _add_bus_options(p: argparse.ArgumentParser, top: bool) -> None:
    """Bus options; on subcommands with SUPPRESS defaults so they never override the top level."""
    present = set(p._option_string_actions)  # noqa: SLF001 - argparse has no public accessor
    d = (lambda v: v) if top else (lambda v: argparse.SUPPRESS)
    g = p.add_argument_group("bus options") if top else p.add_argument_group("bus options (see zenav --help)")
    if "--robot" not in present:
        g.add_argument(
            "--robot",
            default=d(None),
            help="robot name: keys zenav/<robot>/...; '*' = all robots where a command allows it "
            "(default $ZENAV_ROBOT)",
        )
    if "--connect" not in present:
        g.add_argument(
            "--connect",
            action="append",
            default=d(None),
            metavar="ENDPOINT",
            help="Zenoh endpoint to connect to, e.g. tcp/10.0.0.2:7447 (repeatable or comma list)",
        )
    if "--listen" not in present:
        g.add_argument(
            "--listen",
            action="append",
            default=d(None),
            metavar="ENDPOINT",
            help="Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447",
        )
    if "--mode" not in present:
        g.add_argument(
            "--mode", choices=("peer", "client", "router"), default=d(None), help="Zenoh mode (default peer)"
        )
    if "--no-multicast" not in present:
        g.add_argument(
            "--no-multicast",
            action="store_true",
            default=d(False),
            help="disable multicast scouting (then give --connect / --listen)",
        )


def _walk(parser: argparse.ArgumentParser):
    """Every parser below ``parser`` (sub-subcommands included)."""
    for action in parser._actions:  # noqa: SLF001
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for sub in dict.fromkeys(action.choices.values()):
                yield sub
                yield from _walk(sub)


def _broken_command(subparsers, module: str, err: BaseException) -> None:
    name = module.rsplit(".", 1)[-1].removeprefix("cmd_")
    p = subparsers.choices.get(name)  # add_parser may have failed after creating its parser
    if p is None:
        p = subparsers.add_parser(name, help=f"(unavailable: {type(err).__name__})")

    def run(args) -> int:
        print(f"zenav {name}: module {module} failed to load: {type(err).__name__}: {err}", file=sys.stderr)
        return 1

    p.set_defaults(func=run)


def build_parser(commands: list[str] | None = None) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="zenav",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=EPILOG,
        description="zenav: the ROS 1 navigation stack over Eclipse Zenoh — command-line tools.",
    )
    ap.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    _add_bus_options(ap, top=True)
    subparsers = ap.add_subparsers(dest="command", metavar="COMMAND")
    for module in commands if commands is not None else COMMANDS:
        try:
            importlib.import_module(module).add_parser(subparsers)
        except Exception as e:  # noqa: BLE001 - one broken module must not break the others
            _broken_command(subparsers, module, e)
    for sub in _walk(ap):
        _add_bus_options(sub, top=False)
    return ap


def _split(values: list[str] | None) -> list[str]:
    return [x.strip() for v in values or () for x in v.split(",") if x.strip()]


def apply_bus_env(args: argparse.Namespace, env=os.environ) -> None:
    """Export the bus options as ZENAV_* variables (inherited by child processes)."""
    robot = getattr(args, "robot", None)
    if robot and "*" not in robot:
        env["ZENAV_ROBOT"] = robot
    if getattr(args, "connect", None):
        env["ZENAV_CONNECT"] = ",".join(_split(args.connect))
    if getattr(args, "listen", None):
        env["ZENAV_LISTEN"] = ",".join(_split(args.listen))
    if getattr(args, "mode", None):
        env["ZENAV_MODE"] = args.mode
    if getattr(args, "no_multicast", False):
        env["ZENAV_MULTICAST"] = "0"


def _interruptible() -> None:
    """Ctrl-C and SIGQUIT back to their defaults when we were started with them ignored — as every
    command put in the background by a non-interactive shell is (`zenav robot &` in a script): the tools
    would not stop on Ctrl-C, and an agent's nodes (which inherit it) would ignore the SIGINT that stops
    them gracefully."""
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGQUIT) is signal.SIG_IGN:
        signal.signal(signal.SIGQUIT, signal.SIG_DFL)


def main(argv: list[str] | None = None) -> int:
    _interruptible()
    ap = build_parser()
    args = ap.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.WARNING,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    if not getattr(args, "func", None):
        ap.print_help()
        return 2
    apply_bus_env(args)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:  # Ctrl-C: streaming commands stop quietly
        return 0
    except BrokenPipeError:  # `zenav topic echo scan | head`
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the flush at exit
        return 0
    except ValueError as e:  # bad robot / topic names and the like
        print(f"zenav: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 - last safety net: one line, the traceback only with -v
        if args.verbose:
            raise
        print(f"zenav {args.command}: unexpected {type(e).__name__}: {e} (run with -v for the traceback; "
              "please report it)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
