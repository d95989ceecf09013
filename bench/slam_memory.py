"""Memory of the SLAM particle filter: 300 particles on a 100 m x 100 m area (tutorial's gmapping.yaml).

Runs the first scans of a real log with the tutorial's particle count and map bounds, and reports
the bytes held by the particles' maps (shared copy-on-write tiles counted once) against what one
full grid per particle would take, plus the process's peak RSS.
    python bench/slam_memory.py [--scans 400] [--log intel]
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from master_side.slam.gridslam import GridSlam  # noqa: E402
from master_side.slam.logs import read_log  # noqa: E402
from master_side.slam.params import load_gmapping  # noqa: E402

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "datasets" / "slam"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=400, help="scans of the log to process")
    ap.add_argument("--log", default="intel", help="intel or aces")
    ap.add_argument("--particles", type=int, default=300)
    a = ap.parse_args(argv)
    params = load_gmapping(None, particles=a.particles, xmin=-50.0, ymin=-50.0, xmax=50.0, ymax=50.0,
                           delta=0.05, maxUrange=30.0, maxRange=80.0, linearUpdate=0.25, angularUpdate=0.25,
                           temporalUpdate=-1.0, minimumScore=0.0)
    slam = GridSlam(params, track_between=False)
    t0 = time.perf_counter()
    peak_tiles = 0
    updates = 0
    for i, rec in enumerate(read_log(SHARED / f"{a.log}.recon.clf")):
        if i >= a.scans:
            break
        if slam.process(rec.stamp, rec.odom, rec.scan):
            updates += 1
            peak_tiles = max(peak_tiles, slam.memory_bytes())
            print(f"\rscan {i + 1}/{a.scans} updates {updates} tiles {peak_tiles / 2**20:7.1f} MiB",
                  end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    cells = ((params.xmax - params.xmin) / params.delta) * ((params.ymax - params.ymin) / params.delta)
    naive = cells * 4 * a.particles  # one float32 log-odds grid per particle
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    wall = time.perf_counter() - t0
    print(f"{'particles':<26}{a.particles}\n{'area':<26}{params.xmax - params.xmin:.0f} m x "
          f"{params.ymax - params.ymin:.0f} m @ {params.delta} m\n{'scans / filter updates':<26}{a.scans} / {updates}\n"
          f"{'maps, shared tiles once':<26}{peak_tiles / 2**20:.1f} MiB (peak)\n"
          f"{'one full grid / particle':<26}{naive / 2**20:.0f} MiB\n{'process peak RSS':<26}{rss:.0f} MiB\n"
          f"{'wall':<26}{wall:.0f} s")
    print(f"particles={a.particles} area_m={params.xmax - params.xmin:.0f} tiles_peak_mb={peak_tiles / 2**20:.1f} "
          f"naive_mb={naive / 2**20:.0f} peak_rss_mb={rss:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
