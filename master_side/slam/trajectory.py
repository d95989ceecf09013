"""The SLAM trajectory as `zenav slam run` writes it: one pose per scan the filter was given.

``ScanLog`` keeps the stamp and odometry of every scan (what ``offline.run`` keeps); ``poses(slam)``
is ``offline.full_trajectory`` over them. On the bus the trajectory travels as a TFMessage (one
map -> base_link transform per scan, stamped with the scan's stamp: ``to_message`` / ``from_message``);
``write_trajectory`` writes offline's trajectory.txt (``stamp x y theta`` lines, `zenav slam eval`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, TFMessage, TransformStamped
from master_side.slam.gridslam import GridSlam
from master_side.slam.offline import full_trajectory


class ScanLog:
    def __init__(self) -> None:
        self.stamps: list[float] = []
        self.odoms: list[Pose2D] = []

    def add(self, stamp: float, odom: Pose2D) -> None:
        self.stamps.append(stamp)
        self.odoms.append(odom)

    def __len__(self) -> int:
        return len(self.stamps)

    def poses(self, slam: GridSlam | None) -> np.ndarray:
        """(N, 3) pose of every scan, exactly as offline (filter, tracked skipped scans, odometry)."""
        if slam is None or not self.stamps:
            return np.zeros((0, 3))
        return full_trajectory(self.odoms, slam.trajectory(), slam.between)


def to_message(stamps, poses: np.ndarray, frame: str = "map", child: str = "base_link") -> TFMessage:
    return TFMessage(tuple(TransformStamped(Header(float(t), frame), child, Pose2D(*map(float, p)).to_transform())
                           for t, p in zip(stamps, poses)))


def from_message(msg: TFMessage) -> tuple[np.ndarray, np.ndarray]:
    """(stamps (N,), poses (N, 3)) from a trajectory TFMessage."""
    stamps = np.array([ts.header.stamp for ts in msg.transforms], float)
    poses = np.array([ts.transform.to_pose2d().as_array() for ts in msg.transforms], float).reshape(-1, 3)
    return stamps, poses


def write_trajectory(path: str | Path, stamps, poses: np.ndarray) -> None:
    """offline's trajectory.txt format: ``stamp x y theta`` per line."""
    with open(path, "w") as f:
        for t, (x, y, th) in zip(stamps, poses):
            f.write(f"{t:.6f} {x:.6f} {y:.6f} {th:.6f}\n")
