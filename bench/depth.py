"""Per-frame cost of the depth conversions on synthetic VGA / QVGA Kinect-like frames.

Run: python bench/depth.py   (single process; pin with taskset -c 0 for one core)
"cloud VGA" allocates a fresh 3.5 MB array per frame (the published message owns it); where page
faults are expensive (VMs) the "reused out buffer" row shows what the arithmetic itself costs.
Ends with: vga_scan_ms=... qvga_scan_ms=... virtual8_merge_ms=...  (medians)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from common.geometry import Transform  # noqa: E402
from common.messages import CameraInfo, DepthImage, Header  # noqa: E402
from robot_side.depth.cloud import DepthToCloud  # noqa: E402
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams  # noqa: E402
from robot_side.depth.merger import MergerParams, merge_scans  # noqa: E402
from robot_side.depth.virtualizer import Virtualizer, VirtualizerParams, tutorial_planes  # noqa: E402

CAM = Transform.from_xyz_rpy(0.0, 0.0, 0.5, 0.0, 0.0, 0.0)  # base_link <- camera_link
OPTICAL = CAM.compose(Transform.from_xyz_rpy(0.0, 0.0, 0.0, -math.pi / 2, 0.0, -math.pi / 2))


def frame(width: int, height: int, seed: int = 0) -> tuple[DepthImage, CameraInfo]:
    """A level camera 0.5 m up: wall 3 m ahead with a slanted part, floor below, 5 % holes."""
    f = 525.0 * width / 640.0
    info = CameraInfo(Header(0.0, "camera_depth_optical_frame"), width, height, f, f,
                      (width - 1) / 2, (height - 1) / 2)
    v = np.arange(height, dtype=np.float64)[:, None] - info.cy
    u = np.arange(width, dtype=np.float64)[None, :] - info.cx
    wall = 3.0 + 0.5 * np.clip(u / info.fx, 0.0, None) * np.ones_like(v)
    with np.errstate(divide="ignore"):
        ground = np.where(v > 0, 0.5 * info.fy / v, np.inf) * np.ones_like(u)
    depth = np.minimum(wall, ground).astype(np.float32)
    rng = np.random.default_rng(seed)
    depth[rng.random(depth.shape) < 0.05] = 0.0
    return DepthImage(Header(1.0, info.header.frame_id), depth), info


def timeit(fn, n: int) -> np.ndarray:
    fn()  # warm-up (builds the lookup tables)
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return out * 1e3


def main() -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    vga, vga_info = frame(640, 480)
    qvga, qvga_info = frame(320, 240)
    rows: list[tuple[str, np.ndarray]] = []

    d2s = DepthToScan()
    d2s_band = DepthToScan(DepthToScanParams(scan_height=20))
    rows.append(("depth->scan VGA (scan_height=1)", timeit(lambda: d2s.convert(vga, vga_info), 300)))
    rows.append(("depth->scan QVGA (scan_height=1)", timeit(lambda: d2s.convert(qvga, qvga_info), 300)))
    rows.append(("depth->scan VGA (scan_height=20)", timeit(lambda: d2s_band.convert(vga, vga_info), 300)))

    cloud = DepthToCloud()
    planes = tutorial_planes(CAM)
    virt = Virtualizer(planes, VirtualizerParams())
    mp = MergerParams()
    pairs_holder: list = []

    def cloud_only():
        return cloud.points(vga.depth, vga_info)

    def virtual8_merge():
        pts = cloud.points(vga.depth, vga_info)
        scans = virt.scans(pts, vga.header.stamp, OPTICAL)
        pairs_holder[:] = [merge_scans(zip(scans, planes), mp)]

    rows.append(("cloud VGA", timeit(cloud_only, 60)))
    buf = np.empty((vga_info.width * vga_info.height, 3), np.float32)
    rows.append(("cloud VGA (reused out buffer)",
                 timeit(lambda: cloud.points(vga.depth, vga_info, out=buf), 60)))
    pts = cloud_only()
    rows.append(("virtualize 8 planes (VGA cloud)", timeit(lambda: virt.ranges(pts, OPTICAL), 60)))
    scans = virt.scans(pts, 1.0, OPTICAL)
    rows.append(("merge 8 scans", timeit(lambda: merge_scans(zip(scans, planes), mp), 60)))
    rows.append(("cloud + virtualize 8 + merge (VGA)", timeit(virtual8_merge, 60)))

    print(f"{'stage':<38} {'p50 ms':>8} {'p90 ms':>8} {'max ms':>8}")
    for name, t in rows:
        print(f"{name:<38} {np.median(t):8.3f} {np.percentile(t, 90):8.3f} {t.max():8.3f}")
    merged = pairs_holder[0][0]
    hits = int(np.isfinite(merged.ranges).sum())
    print(f"(VGA cloud {len(pts)} points, merged scan {hits}/{len(merged.ranges)} "
          "rays with a return)")
    med = {name: float(np.median(t)) for name, t in rows}
    print(f"vga_scan_ms={med['depth->scan VGA (scan_height=1)']:.3f} "
          f"qvga_scan_ms={med['depth->scan QVGA (scan_height=1)']:.3f} "
          f"virtual8_merge_ms={med['cloud + virtualize 8 + merge (VGA)']:.3f}")


if __name__ == "__main__":
    main()
