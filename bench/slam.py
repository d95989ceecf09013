"""SLAM benchmark: gmapping-style RBPF (or hector, odometry ignored) on the intel and aces logs,
Kümmerle relations metric.

python bench/slam.py [--method gmapping|hector] [--quick] [--particles N] [--datasets intel aces] [--out DIR]
Ends with one line: intel_trans_mean_m=… aces_trans_mean_m=… intel_realtime_factor=… (data time /
wall time) intel_cpu_realtime_factor=… (data time / CPU time: one core, whatever else runs) …
slam_update_ms=… (CPU time of one filter update with all particles, over every update of the logs).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from master_side.slam.evaluate import evaluate, read_relations  # noqa: E402
from master_side.slam.offline import run, write_outputs  # noqa: E402
from master_side.slam.params import load_gmapping  # noqa: E402

SHARED = Path(os.environ.get("ZENAV_SHARED", REPO.parent / "shared")) / "datasets" / "slam"
PUBLISHED_GMAPPING_M = {"intel": 0.070, "aces": 0.060}  # Kümmerle et al. 2009, RBPF (50 particles)
PUBLISHED_SCANMATCH_M = {"intel": 0.220, "aces": 0.173}  # Kümmerle et al. 2009, scan matching
HECTOR_CONFIG = REPO / "master_side" / "config" / "hector_datasets.yaml"
# the datasets' SICK scanners: long ranges, 1 degree beams; 81.83 / 81.91 m = no return
DATASET_PARAMS = dict(maxUrange=30.0, maxRange=80.0, linearUpdate=0.25, angularUpdate=0.25,
                      temporalUpdate=-1.0,
                      minimumScore=0.0, srr=0.1, srt=0.2, str=0.1, stt=0.2, delta=0.05,
                      xmin=-10.0, ymin=-10.0, xmax=10.0, ymax=10.0, resampleThreshold=0.5)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", choices=("gmapping", "hector"), default="gmapping",
                    help="hector: scan matching only, the logs' odometry ignored "
                         "(master_side/config/hector_datasets.yaml)")
    ap.add_argument("--quick", action="store_true", help="only the first 1500 scans of each log")
    ap.add_argument("--particles", type=int, default=30)
    ap.add_argument("--datasets", nargs="+", default=["intel", "aces"])
    ap.add_argument("--out", default="/tmp/zenav_bench_slam", help="where maps and trajectories go")
    ap.add_argument("--no-track", action="store_true", help="odometry-interpolate skipped scans")
    a = ap.parse_args(argv)
    hector = a.method == "hector"
    if hector:
        from master_side.hector import offline as hector_offline
        from master_side.hector.params import load_hector

        params = load_hector(HECTOR_CONFIG)
    else:
        params = load_gmapping(None, **DATASET_PARAMS, particles=a.particles)
    published = PUBLISHED_SCANMATCH_M if hector else PUBLISHED_GMAPPING_M
    rows, summary = [], {}
    updates = [0.0, 0]  # CPU s of the filter updates, their number
    for name in a.datasets:
        log, n = SHARED / f"{name}.recon.clf", 1500 if a.quick else None
        if hector:
            res = hector_offline.run(log, params, n)
            hector_offline.write_outputs(res, Path(a.out) / name)
        else:
            res = run(log, params, n, track_between=not a.no_track)
            write_outputs(res, Path(a.out) / name)
        lo, hi = res.stamps[0], res.stamps[-1]
        rel = [r for r in read_relations(SHARED / f"{name}.relations")
               if lo <= min(r.t1, r.t2) and max(r.t1, r.t2) <= hi]
        s = evaluate(res.stamps, res.poses, rel).summary()
        upd = getattr(res, "update_cpu_s", 0.0)
        cpu_rt = res.data_s / res.cpu_s if res.cpu_s > 0 else float("inf")
        rows.append((name, 0 if hector else a.particles, res.scans, res.processed, res.data_s, res.wall_s, res.cpu_s,
                     res.realtime_factor, cpu_rt, 1000 * upd / max(res.processed, 1), s))
        updates[0] += upd
        updates[1] += res.processed
        summary[f"{name}_trans_mean_m"] = f"{s['trans_mean_m']:.4f}"
        summary[f"{name}_realtime_factor"] = f"{res.realtime_factor:.2f}"
        summary[f"{name}_cpu_realtime_factor"] = f"{cpu_rt:.2f}"
        print(f"{name}: done", file=sys.stderr, flush=True)
    print(f"{'dataset':8} {'part':>4} {'scans':>6} {'proc':>5} {'data s':>7} {'wall s':>7} "
          f"{'cpu s':>7} {'x rt':>6} {'x rt cpu':>8} {'ms/upd':>6} "
          f"{'trans m (mean±std)':>20} {'rot deg (mean±std)':>19} {'rel':>5} "
          f"{'scan-match m' if hector else 'gmapping m':>12}")
    for name, n, scans, proc, data, wall, cpu, rt, cpu_rt, upd_ms, s in rows:
        print(f"{name:8} {n:4d} {scans:6d} {proc:5d} {data:7.1f} {wall:7.1f} {cpu:7.1f} {rt:6.2f} {cpu_rt:8.2f} "
              f"{upd_ms:6.1f} "
              f"{s['trans_mean_m']:9.4f}±{s['trans_std_m']:<9.4f} "
              f"{s['rot_mean_deg']:8.3f}±{s['rot_std_deg']:<8.3f} "
              f"{s['relations']:5d} {published[name]:12.3f}")
    keys = ([f"{d}_trans_mean_m" for d in a.datasets] + [f"{d}_realtime_factor" for d in a.datasets]
            + [f"{d}_cpu_realtime_factor" for d in a.datasets])
    tail = " method=hector" if hector else f" particles={a.particles}"
    if not hector:
        tail += f" slam_update_ms={1000 * updates[0] / max(updates[1], 1):.1f}"
    print(" ".join(f"{k}={summary[k]}" for k in keys) + tail)
    return 0


if __name__ == "__main__":
    sys.exit(main())
