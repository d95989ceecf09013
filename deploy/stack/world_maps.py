"""Known maps of the simulator's worlds, for navigation on a known map (map_server + static layer).

``python -m deploy.stack.world_maps room corridor --out master_side/config/maps`` writes ROS map_server
files (PGM + YAML) rasterised from the world's shapes at the given resolution.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from master_side.mapping.map_io import save_map
from robot_side.sim.world import WorldParams, load_world

WORLDS_DIR = Path(__file__).resolve().parents[2] / "robot_side" / "worlds"


def world_path(name: str) -> Path:
    p = Path(name)
    return p if p.suffix in (".yaml", ".yml") and p.exists() else WORLDS_DIR / f"{name}.yaml"


def export_world_map(name: str, out_dir: str | Path, resolution: float = 0.05, min_height: float = 0.05) -> Path:
    """Rasterise world ``name`` and save ``out_dir/<name>.pgm|.yaml``; returns the YAML path.

    Space the robot cannot reach from the world's start is unknown, as in a map a robot built."""
    world = load_world(world_path(name), WorldParams(resolution=resolution))
    grid = world.to_occupancy_grid(min_height, unknown_unreachable=True)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return save_map(grid, out / Path(name).stem)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("worlds", nargs="+", help="world names (robot_side/worlds) or files")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--resolution", type=float, default=0.05)
    a = ap.parse_args(argv)
    for w in a.worlds:
        print(export_world_map(w, a.out, a.resolution))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
