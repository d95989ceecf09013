"""Depth image -> point cloud (N, 3) float32 in the camera optical frame (z fwd, x right, y down).

Invalid pixels (0, NaN, inf, negative depth) are dropped; ``decimation`` keeps every n-th row and
column (a cheap way to thin a VGA frame). Lookup tables are cached per CameraInfo.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.config import param
from common.messages import CameraInfo, DepthImage, Header, PointCloud

__all__ = ["CloudParams", "DepthToCloud", "depth_to_cloud"]


@dataclass(frozen=True)
class CloudParams:
    decimation: int = param(1, lo=1, hi=64, doc="keep every n-th row and column")
    range_max: float = param(float("inf"), lo=0.0, unit="m", doc="drop pixels deeper than this (inf = keep)")


class DepthToCloud:
    def __init__(self, params: CloudParams | None = None):
        self.params = params or CloudParams()
        self._key: tuple | None = None
        self._xn = self._yn = np.zeros(0, np.float32)
        self._ok = self._tmp = np.zeros(0, bool)

    def _tables(self, info: CameraInfo) -> None:
        key = (info.width, info.height, info.fx, info.fy, info.cx, info.cy, self.params.decimation)
        if key == self._key:
            return
        if info.fx <= 0.0 or info.fy <= 0.0:
            raise ValueError(f"unusable CameraInfo: fx={info.fx} fy={info.fy}")
        s = self.params.decimation
        u = np.arange(0, info.width, s, dtype=np.float64)
        v = np.arange(0, info.height, s, dtype=np.float64)
        xn = ((u - info.cx) / info.fx).astype(np.float32)
        yn = ((v - info.cy) / info.fy).astype(np.float32)
        self._xn = np.broadcast_to(xn[None, :], (len(v), len(u))).ravel()
        self._yn = np.broadcast_to(yn[:, None], (len(v), len(u))).ravel()
        self._key = key

    def points(self, depth: np.ndarray, info: CameraInfo, out: np.ndarray | None = None) -> np.ndarray:
        """(N, 3) float32 points of the valid pixels, row-major pixel order.

        ``out``: an optional reusable (M, 3) float32 buffer; if it is large enough the result is a view
        of its first N rows (so it is overwritten by the next call), else a new array is returned.
        """
        if depth.shape != (info.height, info.width):
            raise ValueError(f"depth image is {depth.shape}, CameraInfo says {(info.height, info.width)}")
        self._tables(info)
        s = self.params.decimation
        d = np.asarray(depth[::s, ::s] if s > 1 else depth, dtype=np.float32).ravel()
        if self._ok.shape != d.shape:
            self._ok = np.empty(d.shape, bool)
            self._tmp = np.empty(d.shape, bool)
        ok = np.greater(d, 0.0, out=self._ok)  # NaN compares False
        rmax = self.params.range_max
        if rmax == float("inf"):
            ok &= np.less(d, np.inf, out=self._tmp)
        else:
            ok &= np.less_equal(d, rmax, out=self._tmp)
        n = int(np.count_nonzero(ok))
        if out is not None and out.dtype == np.float32 and out.ndim == 2 and out.shape[0] >= n \
                and out.shape[1] == 3:
            pts = out[:n]
        else:
            pts = np.empty((n, 3), np.float32)
        z = pts[:, 2]
        np.compress(ok, d, out=z)
        np.compress(ok, self._xn, out=pts[:, 0])
        np.compress(ok, self._yn, out=pts[:, 1])
        pts[:, 0] *= z
        pts[:, 1] *= z
        return pts

    def convert(self, image: DepthImage, info: CameraInfo) -> PointCloud:
        return PointCloud(Header(image.header.stamp, image.header.frame_id or info.header.frame_id),
                          self.points(image.depth, info))


def depth_to_cloud(depth: np.ndarray, info: CameraInfo, decimation: int = 1) -> np.ndarray:
    """One-shot (N, 3) float32 cloud in the optical frame."""
    return DepthToCloud(CloudParams(decimation=decimation)).points(depth, info)
