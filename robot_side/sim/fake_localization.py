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


class FakeLocalization:
    def __init__(self, node: Node) -> None:
        self.node = node
        self.lock = threading.Lock()
        self.pending: dict[str, dict[int, Odometry]] = {"truth": {}, "odom": {}}
        self.pub = node.publisher("tf")
        node.subscribe("ground_truth", Odometry, callback=lambda m: self._on("truth", m), mode="queue")
        node.subscribe("odom", Odometry, callback=lambda m: self._on("odom", m), mode="queue")

    def _on(self, kind: str, msg: Odometry) -> None:
        """Pair ground truth and odometry of the same simulator step (same stamp), then publish."""
        key = round(msg.header.stamp * 1e4)
        other = "odom" if kind == "truth" else "truth"
        with self.lock:
            match = self.pending[other].pop(key, None)
            if match is None:
                self.pending[kind][key] = msg
                for d in self.pending.values():  # keep only the last few unmatched steps
                    for k in sorted(d)[:-20]:
                        del d[k]
                return
        truth, odom = (msg, match) if kind == "truth" else (match, msg)
        self.pub.publish(TFMessage((map_to_odom(truth, odom),)))

    def close(self) -> None:
        pass


def start(node: Node, cfg: dict, source: str) -> FakeLocalization:
    if cfg:
        raise ConfigError(source, sorted(cfg)[0], "fake_localization takes no parameters")
    return FakeLocalization(node)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("fake_localization", start)
