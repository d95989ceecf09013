"""What a running SLAM node says of its scans: received, and dropped by its bounded queue (ROS's 5), from its
``node_stats`` service (what `zenav nodes --stats` prints). A node starved of CPU drops scans, and the update
after a gap integrates all the motion of the gap at once, so a poor map is read beside these counts."""

from __future__ import annotations

from common.bus import Node
from common.messages import Empty, NodeStats, TopicStats


def scan_row(node: Node, slam_node: str = "slam_gmapping", timeout: float = 10.0) -> TopicStats | None:
    """The SLAM node's ``scan`` row of its ``node_stats`` (None: no scan subscription; raises
    common.bus.ServiceError if the node is silent)."""
    stats = node.call(f"node_stats/{slam_node}", Empty(), NodeStats, timeout=timeout)
    return next((t for t in stats.topics if t.topic == "scan"), None)


def scan_counters(node: Node, slam_node: str = "slam_gmapping", timeout: float = 10.0) -> str:
    """``"N scans received, M dropped by its queue"`` (raises common.bus.ServiceError if the node is silent)."""
    scan = scan_row(node, slam_node, timeout)
    return f"{scan.received} scans received, {scan.dropped} dropped by its queue" if scan else "no scan subscription"
