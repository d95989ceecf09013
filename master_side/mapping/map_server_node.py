"""map_server: load a map_server YAML and publish it once on the latched `map` topic."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from common.config import strip_frame
from common.messages import Header
from master_side.mapping.map_io import load_map


class MapServer:
    def __init__(self, node, cfg: dict, source: str):
        yaml_path = cfg.get("map") or cfg.get("yaml_filename")
        if not yaml_path:
            from common.config import ConfigError

            raise ConfigError(source, "map", "path of the map YAML is required")
        path = Path(yaml_path).expanduser()
        if not path.is_absolute():  # relative to the config file, like every other path in it
            path = Path(source).parent / path
        grid = load_map(path)
        frame = strip_frame(str(cfg.get("frame_id", "map")))
        self.grid = replace(grid, header=Header(node.clock.now(), frame))
        self.pub = node.publisher("map", latched=True)
        self.pub.publish(self.grid)

    def close(self) -> None:
        self.pub.close()


def start(node, cfg: dict, source: str) -> MapServer:
    return MapServer(node, cfg, source)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("map_server", start)
