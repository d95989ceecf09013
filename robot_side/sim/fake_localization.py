"""fake_localization: perfect localisation for simulations on a known map (as ROS's fake_localization).

Reads the simulator's ``ground_truth`` (map → base_link) and ``odom`` (odom → base_link) and
publishes ``map → odom`` on ``tf`` so that map → base_link is the true pose. Use it instead of AMCL
or SLAM when the simulated robot navigates on the world's own map.

Parameter (ROS's name and default): ``transform_tolerance`` (s, 0.1) — map → odom is stamped that much
after the step it comes from, as ROS's fake_localization (and amcl) future-date it: a lookup of
map → base_link at the latest time then uses the newest odometry instead of waiting for this node's
extra hop (the pose move_base steers by was that hop old, under load several control cycles).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from common.bus import Node
from common.config import load_params, param
from common.messages import Header, Odometry, TFMessage, TransformStamped


@dataclass(frozen=True)
class FakeLocalizationParams:
    transform_tolerance: float = param(0.1, lo=0.0, hi=10.0, unit="s",
                                       doc="map -> odom is stamped this much after its simulator step")


def map_to_odom(truth: Odometry, odom: Odometry, future_date: float = 0.0) -> TransformStamped:
    """map→odom = (map→base) ∘ (odom→base)⁻¹, stamped with the odometry's stamp + ``future_date``."""
    t = truth.pose2d.compose(odom.pose2d.inverse())
    return TransformStamped(Header(odom.header.stamp + future_date, truth.header.frame_id or "map"),
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
    def __init__(self, node: Node, params: FakeLocalizationParams = FakeLocalizationParams()) -> None:
        self.node, self.p = node, params
        self.lock = threading.Lock()
        self.pairs = StepPairer()
        self.pub = node.publisher("tf")
        node.subscribe("ground_truth", Odometry, callback=lambda m: self._on("truth", m), mode="queue")
        node.subscribe("odom", Odometry, callback=lambda m: self._on("odom", m), mode="queue")

    def _on(self, kind: str, msg: Odometry) -> None:
        with self.lock:
            pair = self.pairs.add(kind, msg)
        if pair is not None:
            self.pub.publish(TFMessage((map_to_odom(*pair, self.p.transform_tolerance),)))

    def close(self) -> None:
        pass


def check(cfg: dict, source: str) -> list[str]:
    """The agents' parameter check (common.node_check)."""
    load_params(FakeLocalizationParams, cfg, source)
    return []


def start(node: Node, cfg: dict, source: str) -> FakeLocalization:
    return FakeLocalization(node, load_params(FakeLocalizationParams, cfg, source))


if __name__ == "__main__":
    from common.runner import node_main

    node_main("fake_localization", start)
