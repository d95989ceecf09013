"""fake_localization: perfect localisation for simulations on a known map (as ROS's fake_localization).

Reads the simulator's ``ground_truth`` (map → base_link) and ``odom`` (odom → base_link) and
publishes ``map → odom`` on ``tf`` so that map → base_link is the true pose. Use it instead of AMCL
or SLAM when the simulated robot navigates on the world's own map.
"""

from __future__ import annotations

import threading

from common.bus import Node
from common.config import ConfigError
from common.messages import Header, Odometry, TFMessage, TransformStamped


def map_to_odom(truth: Odometry, odom: Odometry) -> TransformStamped:
    """map→odom = (map→base) ∘ (odom→base)⁻¹, stamped with the odometry's stamp."""
    t = truth.pose2d.compose(odom.pose2d.inverse())
    return TransformStamped(Header(odom.header.stamp, truth.header.frame_id or "map"),
                            odom.header.frame_id or "odom", t.to_transform())


# Unmatched steps kept per input. Each input has its own subscription queue (100 messages) and delivery
# thread, so on a starved CPU one input can run up to a whole queue behind the other; with 20 kept, a skew
# over 20 steps paired nothing ever again (a CI run under a CPU hog: map->odom stopped at the start and
# every goal failed with 'no robot pose'). Twice the queue covers any skew the queues allow.
KEEP = 200


class StepPairer:
    """Pairs ground truth and odometry of the same simulator step (same stamp), whichever comes first."""

    def __init__(self, keep: int = KEEP) -> None:
        self.keep = keep
        self.pending: dict[str, dict[int, Odometry]] = {"truth": {}, "odom": {}}

    def add(self, kind: str, msg: Odometry) -> tuple[Odometry, Odometry] | None:
        """``kind`` "truth" or "odom": (truth, odom) once both of ``msg``'s step are in, else None."""
        key = round(msg.header.stamp * 1e4)
        match = self.pending["odom" if kind == "truth" else "truth"].pop(key, None)
        if match is None:
            d = self.pending[kind]  # the last ``keep`` unmatched steps of this input (one publisher, one
            d[key] = msg  # queue: they come in stamp order, so the first inserted is the oldest)
            if len(d) > self.keep:
                del d[next(iter(d))]
            return None
        return (msg, match) if kind == "truth" else (match, msg)


class FakeLocalization:
    def __init__(self, node: Node) -> None:
        self.node = node
        self.lock = threading.Lock()
        self.pairs = StepPairer()
        self.pub = node.publisher("tf")
        node.subscribe("ground_truth", Odometry, callback=lambda m: self._on("truth", m), mode="queue")
        node.subscribe("odom", Odometry, callback=lambda m: self._on("odom", m), mode="queue")

    def _on(self, kind: str, msg: Odometry) -> None:
        with self.lock:
            pair = self.pairs.add(kind, msg)
        if pair is not None:
            self.pub.publish(TFMessage((map_to_odom(*pair),)))

    def close(self) -> None:
        pass


def start(node: Node, cfg: dict, source: str) -> FakeLocalization:
    if cfg:
        raise ConfigError(source, sorted(cfg)[0], "fake_localization takes no parameters")
    return FakeLocalization(node)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("fake_localization", start)
