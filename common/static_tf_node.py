"""Static transform publisher node (ROS ``tf static_transform_publisher``) on latched ``tf_static``.

Config (YAML mapping), either one transform::

    args: "0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"

or several, named like the ROS launch nodes (e.g. ../shared/reference/p3at/static_transforms.yaml)::

    Pioneer3AT_laserscan_tf:
      args: "0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"

Run: ``python -m common.static_tf_node --config static_transforms.yaml``. The period argument is
accepted for compatibility; a latched ``tf_static`` message makes republishing unnecessary.
"""

from __future__ import annotations

from common.config import ConfigError
from common.messages import TransformStamped
from common.tf import StaticTFBroadcaster, parse_static_args


def load_static_transforms(cfg: dict, source: str = "<config>", stamp: float = 0.0) -> list[TransformStamped]:
    """The transforms described by ``cfg``; raises ConfigError naming the file and key."""
    if not isinstance(cfg, dict) or not cfg:
        raise ConfigError(source, "<file>", "expected 'args: \"x y z yaw pitch roll frame child\"' or a "
                                            "mapping of name -> {args: ...}")
    entries = [("args", cfg["args"])] if "args" in cfg else []
    for name, sub in cfg.items():
        if name == "args":
            continue
        if not isinstance(sub, dict) or set(sub) != {"args"}:
            raise ConfigError(source, str(name), "expected a mapping with only the key 'args'")
        entries.append((f"{name}.args", sub["args"]))
    out: dict[str, TransformStamped] = {}
    for key, args in entries:
        if not isinstance(args, (str, list)):
            raise ConfigError(source, key, f"expected a string of arguments, got {args!r}")
        try:
            ts, _period = parse_static_args(args, stamp=stamp)
        except ValueError as e:
            raise ConfigError(source, key, str(e)) from None
        if ts.child_frame_id in out:
            raise ConfigError(source, key, f"frame {ts.child_frame_id!r} already has a static parent "
                                           f"({out[ts.child_frame_id].header.frame_id!r})")
        out[ts.child_frame_id] = ts
    return list(out.values())


class StaticTFNode:
    def __init__(self, node, transforms: list[TransformStamped]) -> None:
        self.transforms = transforms
        self.broadcaster = StaticTFBroadcaster(node)
        self.broadcaster.send(transforms)
        for ts in transforms:
            node.log.info("static transform %s -> %s", ts.header.frame_id, ts.child_frame_id)

    def close(self) -> None:
        self.broadcaster.close()


def start(node, cfg: dict, source: str) -> StaticTFNode:
    return StaticTFNode(node, load_static_transforms(cfg, source, stamp=node.clock.now()))


if __name__ == "__main__":
    from common.runner import run_main

    run_main("static_transform_publisher", start)
