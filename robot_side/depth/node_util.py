"""Small helpers shared by the robot-side bus adapters (depth, bumpers, sonar, the simulator); no bus import here."""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from typing import Any

from common.config import load_params
from common.log_util import RateLimitedLog


def split_params(cfg: dict | None, source: str, *classes: type, section: str = "") -> list[Any]:
    """Load one YAML mapping into several parameter dataclasses (each key goes to the class that has it).

    Keys known to none of them are left to the last class, so load_params reports them as unknown.
    """
    cfg = dict(cfg or {})
    owned: list[dict] = [{} for _ in classes]
    for key, value in cfg.items():
        for i, cls in enumerate(classes):
            names = set()
            for f in dataclasses.fields(cls):
                names.add(f.name)
                names.update(f.metadata.get("aliases", ()))
            if key in names:
                owned[i][key] = value
                break
        else:
            owned[-1][key] = value
    return [load_params(cls, data, source=source, section=section) for cls, data in zip(classes, owned)]


class Handles:
    """Closes everything it holds, in reverse order."""

    def __init__(self, *items: Any) -> None:
        self.items = list(items)

    def add(self, item: Any) -> Any:
        self.items.append(item)
        return item

    def close(self) -> None:
        for item in reversed(self.items):
            with contextlib.suppress(Exception):  # best effort on shutdown
                item.close()
        self.items = []


def convert_stream(node, in_topic: str, in_type: type, out_topic: str, convert: Callable[[Any], Any]) -> Handles:
    """Publish ``convert(msg)`` on ``out_topic`` for every message of ``in_topic`` (queued: none is skipped)."""
    h = Handles()
    pub = h.add(node.publisher(out_topic))
    h.add(node.subscribe(in_topic, in_type, callback=lambda msg: pub.publish(convert(msg)), mode="queue"))
    return h


def convert_depth_stream(node, image_topic: str, info_topic: str, out_topic: str, convert, log) -> Handles:
    """Wire ``convert(DepthImage, CameraInfo) -> message`` between a depth stream and ``out_topic``.

    The image subscription is keep-latest: a slow conversion drops stale frames instead of queueing.
    """
    from common.messages import CameraInfo, DepthImage

    h = Handles()
    warn = RateLimitedLog()
    pub = h.add(node.publisher(out_topic))
    info_sub = h.add(node.subscribe(info_topic, CameraInfo))

    def on_image(img: DepthImage) -> None:
        info = info_sub.latest()
        if info is None:
            log.debug("depth image before any camera_info: dropped")
            return
        if img.depth.shape != (info.height, info.width):
            warn(log, f"depth image {img.depth.shape[1]}x{img.depth.shape[0]} does not match camera_info "
                      f"{info.width}x{info.height}: dropped")
            return
        pub.publish(convert(img, info))

    h.add(node.subscribe(image_topic, DepthImage, callback=on_image))
    return h
