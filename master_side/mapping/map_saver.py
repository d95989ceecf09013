"""map_saver: wait for one message on `map` and write it as map_server PGM + YAML."""

from __future__ import annotations

import argparse
import sys

from common.messages import OccupancyGrid
from master_side.mapping.map_io import save_map


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="zenav map save", description="save the `map` topic to PGM + YAML")
    ap.add_argument("-f", "--file", default="map", help="output base name (writes NAME.pgm and NAME.yaml)")
    ap.add_argument("--topic", default="map")
    ap.add_argument("--robot", default=None)
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds to wait for a map")
    ap.add_argument("--free", type=int, default=25, help="occupancy at or below this is free")
    ap.add_argument("--occupied", type=int, default=65, help="occupancy at or above this is occupied")
    a = ap.parse_args(argv)
    from common.bus import Node

    node = Node("map_saver", robot=a.robot)
    try:
        sub = node.subscribe(a.topic, OccupancyGrid)
        try:
            grid = sub.wait_first(a.timeout)
        except TimeoutError:
            grid = None
        if grid is None:
            print(f"error: no map on '{a.topic}' within {a.timeout} s", file=sys.stderr)
            return 1
        yp = save_map(grid, a.file, a.free, a.occupied)
        print(f"saved {grid.width} x {grid.height} map at {grid.resolution} m/cell to {yp}")
        return 0
    finally:
        node.close()


if __name__ == "__main__":
    sys.exit(main())
