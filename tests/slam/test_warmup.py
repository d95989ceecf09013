"""The slam_gmapping node loads every kernel of a filter update before it takes its first scan
(``master_side.slam.warmup``): a kernel loaded inside the first update stalls the filter, and the stall
becomes a gap in the scans that a symmetric room is then matched wrongly across (the room demo's test
failed in 4 of 9 runs with a cold kernel cache, and passed 4 of 4 with the warm-up, every map at 100 %)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from deploy.stack.process_group import checkout_env

REPO = Path(__file__).resolve().parents[2]

# a fresh process: the kernels' compiled signatures after the warm-up, then after real updates of the
# tutorial's filter (its gmapping.yaml, as the P3-AT demo runs it) on a Kinect-wide scan of another size
SCRIPT = """
import json, numba
from common.geometry import Pose2D
from master_side.slam import kernels, map_kernels
from master_side.slam.gridslam import GridSlam
from master_side.slam.params import load_gmapping
from master_side.slam.warmup import room_scan, warm_filter

def signatures():
    return {f"{m.__name__}.{k}": len(v.signatures) for m in (kernels, map_kernels) for k, v in vars(m).items()
            if isinstance(v, numba.core.registry.CPUDispatcher)}

warm_filter()
warm = signatures()
slam = GridSlam(load_gmapping(%r), laser=Pose2D(0.1, 0.0, 0.0))
for k in range(6):
    x, th = -1.0 + 0.4 * k, 0.25 * k
    slam.process(float(k), Pose2D(x, 0.1, th), room_scan(x, 0.1, th, 640))
slam.occupancy_grid()
print(json.dumps({"warm": warm, "after": signatures(), "updates": slam.processed}))
"""


def test_the_warm_up_loads_every_kernel_a_real_update_uses(shared_dir):
    gmapping = shared_dir / "reference/p3at/gmapping.yaml"
    out = subprocess.run([sys.executable, "-c", SCRIPT % str(gmapping)], env=checkout_env(drop_zenav=True),
                         cwd=REPO, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["updates"] >= 3, r  # the updates matched scans (not only the first scan's initialisation)
    assert sum(r["warm"].values()) >= 5, r["warm"]  # the entry kernels were loaded by the warm-up
    added = {k: (r["warm"][k], n) for k, n in r["after"].items() if n != r["warm"].get(k)}
    assert not added, f"kernels loaded or compiled in the first real updates, not by the warm-up: {added}"
