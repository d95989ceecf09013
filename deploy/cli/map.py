"""``zenav map save``: write the `map` topic as ROS map_server files (PGM + YAML)."""

from __future__ import annotations

import argparse

from common.argtypes import positive


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("map", help="save the current map (like map_saver)",
                              description="zenav map save [-f NAME]: wait for one `map` message and write "
                                          "NAME.pgm + NAME.yaml as ROS map_server does (trinary, 0.65/0.196).")
    p.add_argument("action", choices=("save",))
    p.add_argument("-f", "--file", default="map", help="output base name (default: map)")
    p.add_argument("--topic", default="map")
    p.add_argument("--timeout", type=positive, default=30.0, help="seconds to wait for a map")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from master_side.mapping.map_saver import main

    argv = ["--file", args.file, "--topic", args.topic, "--timeout", str(args.timeout)]
    if getattr(args, "robot", None) and "*" not in args.robot:
        argv += ["--robot", args.robot]
    return main(argv)
