"""map_server: load a map_server YAML and publish it once on the latched `map` topic.

Parameters: ``map`` (or ROS's ``yaml_filename``): the map YAML, relative to the config file;
``frame_id`` (default map).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from common.config import ConfigError, load_params, param, strip_frame
from common.messages import Header, OccupancyGrid
from master_side.mapping.map_io import MapFormatError, load_map


@dataclass(frozen=True)
class MapServerParams:
    map: str = param("", aliases=("yaml_filename",), doc="map_server YAML (relative to the config file)")
    frame_id: str = param("map", doc="frame of the published map")


def load(cfg: dict, source: str) -> tuple[OccupancyGrid, str]:
    """The map and its frame; every problem as a ConfigError."""
    p = load_params(MapServerParams, cfg, source)
    if not p.map:
        raise ConfigError(source, "map", "path of the map YAML is required")
    path = Path(p.map).expanduser()
    if not path.is_absolute():  # relative to the config file, like every other path in it
        path = Path(source).parent / path
    if not path.is_file():
        raise ConfigError(source, "map", f"file not found: {path}")
    try:
        return load_map(path), strip_frame(p.frame_id)
    except MapFormatError as e:
        raise ConfigError(source, "map", str(e)) from None


def check(cfg: dict, source: str) -> list[str]:
    """Parameters and map checked without the bus (the agents call this before starting anything)."""
    load(cfg, source)
    return []


class MapServer:
    def __init__(self, node, cfg: dict, source: str):
        grid, frame = load(cfg, source)
        self.grid = replace(grid, header=Header(node.clock.now(), frame))
        self.pub = node.publisher("map", latched=True, reliable=True)  # a whole map: never dropped in fragments
        self.pub.publish(self.grid)

    def close(self) -> None:
        self.pub.close()


def start(node, cfg: dict, source: str) -> MapServer:
    return MapServer(node, cfg, source)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("map_server", start)
