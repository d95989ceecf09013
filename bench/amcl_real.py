"""AMCL on real buildings' logs: the intel and aces logs replayed against the map our SLAM builds from them.

python bench/amcl_real.py [--datasets intel aces] [--seeds 5] [--track-seeds 2] [--quick] [--out DIR]
                          [--odom-noise ros|measured] [--laser-noise ros|measured] [--refine]

Per log, once: gmapping-style SLAM (bench/slam.py's parameters) over the log gives the map and a trajectory;
both are cached in ``--out`` (keyed by the log file and the SLAM parameters, so a rerun only replays AMCL).
Then every scan with its odometry goes into ``Amcl`` in one process, with ROS amcl's default parameters
(the tutorial's names; only laser_max_range is set, to the log's scanner: see LASER_MAX_RANGE_M):

- tracking: the initial pose is SLAM's first pose moved 1 m in each of 4 directions (+x, +y, -x, -y of the
  map) and turned ±30°, with the spread a user's initial pose gets in ROS (the initial_cov_* defaults:
  0.5 m and π/12 rad standard deviations), ``--track-seeds`` seeds each;
- global localisation: ``global_localization()`` (particles uniform over the map's free cells), ``--seeds``
  seeds.

AMCL's pose at a scan is map_to_odom() ∘ odometry after that scan. Figures per run:
- relations error: the Kümmerle relations metric (``zenav slam eval``'s) on AMCL's pose at every scan of the
  whole log, the first unconverged seconds included; "tracked": the same over the relations that begin once
  AMCL has converged (see below), spells over the bounds afterwards included;
- absolute error against SLAM's own trajectory (the map's frame), after convergence: mean and 95th percentile;
- converged: the absolute error under 0.3 m and 0.2 rad; converge time: data time from the first scan to the
  first scan from which it stays converged for 10 s of data; lost: after that, 10 s of data in which it is
  never converged; out: the share of the scans after convergence that are not converged (short excursions,
  e.g. along a featureless corridor). A run (tracking or global) succeeds if it converges and is never lost.

SLAM's map is built from the very scans AMCL then sees, so the map holds no change the robot has not seen:
these are best-case figures for the map, real ones for the odometry and the laser.
Ends with one line: amcl_real_trans_mean_m=… (relations error, mean over all tracking runs)
amcl_real_converge_s=… (median tracking converge time) amcl_real_global_success=k/n, then per-log keys.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench.slam import DATASET_PARAMS, SHARED  # noqa: E402
from common.geometry import Pose2D  # noqa: E402
from common.messages import OccupancyGrid  # noqa: E402
from common.robot_logs import CARMEN_MAX_RANGE, ScanRecord  # noqa: E402
from master_side.localization.amcl import Amcl  # noqa: E402
from master_side.localization.laser_noise import end_point_distances  # noqa: E402
from master_side.localization.laser_noise import fit as fit_laser_noise  # noqa: E402
from master_side.localization.likelihood_field import LikelihoodField  # noqa: E402
from master_side.localization.odom_noise import fit as fit_odom_noise  # noqa: E402
from master_side.localization.params import AmclParams, load_amcl_params  # noqa: E402
from master_side.mapping.map_io import load_map  # noqa: E402
from master_side.slam.evaluate import Relation, evaluate, read_relations, read_trajectory  # noqa: E402
from master_side.slam.logs import read_log  # noqa: E402
from master_side.slam.offline import run as slam_run  # noqa: E402
from master_side.slam.offline import write_outputs  # noqa: E402
from master_side.slam.params import load_gmapping  # noqa: E402

# The only AMCL settings the logs need (every other value is ROS amcl's default): laser_max_range, the range
# at and beyond which a reading is "no return". intel's SICK reports 81.83 m for no return, which the reader
# already maps beyond its 80 m range_max (CARMEN_MAX_RANGE, as bench/slam.py's maxRange). aces was logged
# with a 50 m cap (../shared/datasets/slam/README.md): its 50.0 readings (0.8 % of them) are no returns.
LASER_MAX_RANGE_M = {"intel": CARMEN_MAX_RANGE, "aces": 50.0}
CONVERGED_M, CONVERGED_RAD = 0.3, 0.2  # absolute error under both = converged
HOLD_S = 10.0  # converged (or not) for this long, in data time, to count as converged (or lost)
OFFSET_M, OFFSET_RAD = 1.0, math.radians(30.0)
DIRECTIONS = ((1.0, 0.0, "+x"), (0.0, 1.0, "+y"), (-1.0, 0.0, "-x"), (0.0, -1.0, "-y"))
QUICK_SCANS = 1500
MEASURE_SHARE = 0.25  # --odom-noise measured: fitted on this share of the log, from its start


@dataclass(frozen=True)
class SlamRef:
    """SLAM's map of a log, its pose at every scan (the reference frame) and its own relations error."""
    grid: OccupancyGrid
    stamps: np.ndarray
    poses: np.ndarray
    trans_mean_m: float
    rot_mean_deg: float


@dataclass(frozen=True)
class RunFigures:
    mode: str  # "track" or "global"
    start: str
    seed: int
    updates: int
    trans_mean_m: float  # relations metric, whole log
    rot_mean_deg: float
    trans_tracked_m: float  # relations metric over the relations after convergence (nan if never converged)
    abs_mean_m: float  # against SLAM, after convergence (nan if never)
    abs_p95_m: float
    converge_s: float  # inf = never converged
    lost_s: float  # inf = never lost after converging
    out_pct: float  # scans after convergence that are not converged, % (nan if never converged)
    cpu_s: float

    @property
    def success(self) -> bool:
        return math.isfinite(self.converge_s) and not math.isfinite(self.lost_s)


@dataclass(frozen=True)
class Convergence:
    first: int | None  # the scan from which it stayed converged for HOLD_S (None: never)
    lost: int | None  # after that, the first scan of HOLD_S never converged (None: never lost)
    out_share: float  # share of the scans from ``first`` on that are not converged


# -- inputs ---------------------------------------------------------------------------------------------
def read_records(log: Path, max_scans: int | None) -> list[ScanRecord]:
    """The log's scans with their odometry, the first ``max_scans`` of them (all with None)."""
    out = []
    for rec in read_log(log):
        if max_scans is not None and len(out) >= max_scans:
            break
        out.append(rec)
    return out


def relations_within(path: Path, lo: float, hi: float) -> list[Relation]:
    """The relations whose two stamps lie in [lo, hi] (a slice of the log sees only these)."""
    return [r for r in read_relations(path) if lo <= min(r.t1, r.t2) and max(r.t1, r.t2) <= hi]


def slam_reference(log: Path, relations: Path, max_scans: int | None, out: Path,
                   progress=sys.stderr) -> SlamRef:
    """SLAM over the log with bench/slam.py's parameters, cached in ``out`` under a key of the log file
    (name, size, modification time), the scan count and the parameters."""
    params = load_gmapping(None, **DATASET_PARAMS)
    st = log.stat()
    key = {"log": log.name, "size": st.st_size, "mtime_ns": st.st_mtime_ns, "max_scans": max_scans,
           "track_between": True, "params": {k: repr(v) for k, v in asdict(params).items()}}
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]
    d = out / f"{log.name.split('.')[0]}-{digest}"
    meta = d / "slam.json"
    if not meta.exists():
        res = slam_run(log, params, max_scans, progress=progress)
        write_outputs(res, d)
        s = evaluate(res.stamps, res.poses, relations_within(relations, res.stamps[0], res.stamps[-1])).summary()
        meta.write_text(json.dumps({"key": key, "trans_mean_m": s["trans_mean_m"],
                                    "rot_mean_deg": s["rot_mean_deg"], "slam_cpu_s": res.cpu_s}, indent=1))
    m = json.loads(meta.read_text())
    stamps, poses = read_trajectory(d / "trajectory.txt")
    return SlamRef(load_map(d / "map.yaml"), stamps, poses, m["trans_mean_m"], m["rot_mean_deg"])


def amcl_params(dataset: str, sets: dict | None = None) -> AmclParams:
    """ROS amcl's defaults with the log's laser range (and ``sets``, to compare settings)."""
    return load_amcl_params({"laser_max_range": LASER_MAX_RANGE_M[dataset], **(sets or {})}, "bench/amcl_real")


def measured_odom_noise(records: list[ScanRecord], ref: SlamRef, share: float = MEASURE_SHARE) -> dict:
    """amcl's odom_alpha1..4 for ROS's default ``diff`` model, measured on the first ``share`` of the log
    (its odometry against SLAM's trajectory, `zenav slam odom-noise`'s fit)."""
    k = max(int(len(records) * share), 3)
    n = fit_odom_noise(np.array([r.odom.as_array() for r in records[:k]]), ref.poses[:k], "diff")
    return {f"odom_alpha{i}": round(getattr(n, f"alpha{i}"), 4) for i in range(1, 5)}


def measured_laser_noise(name: str, records: list[ScanRecord], ref: SlamRef, share: float = MEASURE_SHARE) -> dict:
    """amcl's laser_sigma_hit measured on the first ``share`` of the log: the scans' end points seen from
    SLAM's trajectory against SLAM's map (`zenav slam laser-noise`'s fit)."""
    k = max(int(len(records) * share), 1)
    p = amcl_params(name)
    field = LikelihoodField(ref.grid, p.laser_likelihood_max_dist, p.laser_penalize_interior)
    d = end_point_distances(field, ref.poses[:k], ((r.scan.ranges, r.scan.angles()) for r in records[:k]),
                            Pose2D(), records[0].scan.range_min, p.laser_max_range)
    return {"laser_sigma_hit": round(fit_laser_noise(d, p.laser_likelihood_max_dist).sigma_hit, 4)}


def tracking_starts(first: Pose2D) -> list[tuple[str, Pose2D]]:
    """SLAM's first pose moved 1 m along each map axis, turned +30° (+x, -x) or -30° (+y, -y)."""
    out = []
    for k, (dx, dy, name) in enumerate(DIRECTIONS):
        turn = OFFSET_RAD if k % 2 == 0 else -OFFSET_RAD
        out.append((f"{name} 1m {math.degrees(turn):+.0f}deg",
                    Pose2D(first.x + OFFSET_M * dx, first.y + OFFSET_M * dy, first.theta + turn)))
    return out


# -- the replay and its figures -------------------------------------------------------------------------
def replay(records: list[ScanRecord], grid: OccupancyGrid, params: AmclParams, seed: int,
           start: Pose2D | None) -> tuple[np.ndarray, int, float]:
    """AMCL over the records from ``start`` (with the initial_cov_* spread) or, if None, from a global
    localisation. Returns (AMCL's map pose at every scan (N, 3), filter updates, CPU s)."""
    amcl = Amcl(params, grid, Pose2D(), rng=np.random.default_rng(seed))
    if start is None:
        amcl.global_localization()
    else:
        amcl.init_pose(start, (params.initial_cov_xx, params.initial_cov_yy, params.initial_cov_aa))
    poses = np.empty((len(records), 3))
    c0 = time.process_time()
    for i, rec in enumerate(records):
        amcl.update(rec.odom, rec.scan)
        poses[i] = amcl.map_to_odom().compose(rec.odom).as_array()
    return poses, amcl.updates, time.process_time() - c0


def absolute_errors(poses: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation (m) and |yaw| (rad) error of every pose (N, 3) against the reference (N, 3)."""
    d = poses - ref
    return np.hypot(d[:, 0], d[:, 1]), np.abs(np.remainder(d[:, 2] + np.pi, 2 * np.pi) - np.pi)


def convergence(stamps: np.ndarray, trans: np.ndarray, rot: np.ndarray, hold_s: float = HOLD_S) -> Convergence:
    """When the errors (per scan) got under the thresholds for ``hold_s`` of data, and whether they later
    stayed over them for ``hold_s`` (a window must fit in the log to count)."""
    inside = (trans < CONVERGED_M) & (rot < CONVERGED_RAD)
    idx = np.arange(len(inside))
    end = np.searchsorted(stamps, stamps + hold_s)  # window of scan i: scans i .. end[i] - 1
    cum = np.concatenate(([0], np.cumsum(inside)))
    count = cum[end] - cum[idx]  # converged scans in each window
    fits = stamps + hold_s <= stamps[-1]
    all_in, all_out = fits & (count == end - idx), fits & (count == 0)
    if not all_in.any():
        return Convergence(None, None, math.nan)
    k = int(np.argmax(all_in))
    lost = np.nonzero(all_out[k:])[0]
    return Convergence(k, k + int(lost[0]) if len(lost) else None, float(1.0 - inside[k:].mean()))


def figures(mode: str, start: str, seed: int, poses: np.ndarray, updates: int, cpu_s: float, ref: SlamRef,
            relations: list[Relation]) -> RunFigures:
    s = evaluate(ref.stamps, poses, relations).summary()
    trans, rot = absolute_errors(poses, ref.poses)
    c = convergence(ref.stamps, trans, rot)
    after = trans[c.first:] if c.first is not None else np.array([np.nan])

    def since_start(k: int | None) -> float:
        return float(ref.stamps[k] - ref.stamps[0]) if k is not None else math.inf

    tracked = math.nan
    if c.first is not None:
        t_conv = ref.stamps[c.first]
        later = [r for r in relations if min(r.t1, r.t2) >= t_conv]
        if later:
            tracked = evaluate(ref.stamps, poses, later).summary()["trans_mean_m"]
    return RunFigures(mode, start, seed, updates, s["trans_mean_m"], s["rot_mean_deg"], tracked, float(np.mean(after)),
                      float(np.percentile(after, 95)), since_start(c.first), since_start(c.lost),
                      100.0 * c.out_share, cpu_s)


# -- the bench ------------------------------------------------------------------------------------------
def bench_log(name: str, max_scans: int | None, seeds: int, track_seeds: int, out: Path, sets: dict,
              progress=sys.stderr, odom_noise: str = "ros",
              laser_noise: str = "ros") -> tuple[SlamRef, list[RunFigures]]:
    log, rel_path = SHARED / f"{name}.recon.clf", SHARED / f"{name}.relations"
    progress.write(f"{name}: SLAM map (cached in {out})\n")
    ref = slam_reference(log, rel_path, max_scans, out, progress)
    records = read_records(log, max_scans)
    if len(records) != len(ref.stamps) or not np.allclose([r.stamp for r in records], ref.stamps, atol=1e-5):
        raise RuntimeError(f"{name}: the cached SLAM trajectory does not match the log's scans")
    relations = relations_within(rel_path, ref.stamps[0], ref.stamps[-1])
    if odom_noise == "measured":
        sets = {**measured_odom_noise(records, ref), **sets}
        progress.write(f"{name}: odometry noise measured on the first {MEASURE_SHARE:.0%} of the log: {sets}\n")
    if laser_noise == "measured":
        sets = {**measured_laser_noise(name, records, ref), **sets}
        progress.write(f"{name}: laser noise measured on the first {MEASURE_SHARE:.0%} of the log: "
                       f"laser_sigma_hit {sets['laser_sigma_hit']}\n")
    params = amcl_params(name, sets)
    runs = [("track", label, seed, start) for seed in range(track_seeds)
            for label, start in tracking_starts(Pose2D(*ref.poses[0]))]
    runs += [("global", "uniform", seed, None) for seed in range(seeds)]
    rows = []
    for i, (mode, label, seed, start) in enumerate(runs, 1):
        poses, updates, cpu = replay(records, ref.grid, params, seed + 1, start)
        rows.append(figures(mode, label, seed, poses, updates, cpu, ref, relations))
        r = rows[-1]
        progress.write(f"{name}: run {i}/{len(runs)} {mode} {label} seed {seed}: relations {r.trans_mean_m:.4f} m, "
                       f"converged at {r.converge_s:.1f} s, lost at {r.lost_s:.1f} s, cpu {cpu:.1f} s\n")
        progress.flush()
    return ref, rows


def print_table(name: str, ref: SlamRef, rows: list[RunFigures], scans: int, data_s: float) -> None:
    print(f"\n{name}: {scans} scans, {data_s:.0f} s of data; SLAM's own relations error "
          f"{ref.trans_mean_m:.4f} m / {ref.rot_mean_deg:.3f} deg")
    print(f"{'mode':6} {'start':16} {'seed':>4} {'updates':>7} {'rel trans m':>11} {'rel rot deg':>11} "
          f"{'tracked m':>9} "
          f"{'abs mean m':>10} {'abs p95 m':>9} {'converge s':>10} {'lost s':>7} {'out %':>5} {'cpu s':>6}")
    for r in rows:
        print(f"{r.mode:6} {r.start:16} {r.seed:4d} {r.updates:7d} {r.trans_mean_m:11.4f} {r.rot_mean_deg:11.3f} "
              f"{r.trans_tracked_m:9.4f} "
              f"{r.abs_mean_m:10.4f} {r.abs_p95_m:9.4f} {r.converge_s:10.1f} {r.lost_s:7.1f} {r.out_pct:5.1f} "
              f"{r.cpu_s:6.1f}")


def summary_line(results: dict[str, tuple[SlamRef, list[RunFigures]]]) -> str:
    """amcl_real_trans_mean_m: relations error, mean over the tracking runs; amcl_real_converge_s: their median
    converge time (inf when most never converge); *_success: runs that converged and were never lost."""
    def runs(mode: str, names=tuple(results)) -> list[RunFigures]:
        return [r for n in names for r in results[n][1] if r.mode == mode]

    def ok(rows: list[RunFigures]) -> str:
        return f"{sum(r.success for r in rows)}/{len(rows)}"

    def mean(values: list[float], fmt: str = ".4f") -> str:
        return f"{np.mean(values):{fmt}}" if values else "nan"

    def median(values: list[float]) -> str:
        return f"{np.median(values):.1f}" if values else "nan"

    track, glob = runs("track"), runs("global")
    keys = {"amcl_real_trans_mean_m": mean([r.trans_mean_m for r in track]),
            "amcl_real_trans_tracked_m": mean([r.trans_tracked_m for r in track if math.isfinite(r.trans_tracked_m)]),
            "amcl_real_converge_s": median([r.converge_s for r in track]),
            "amcl_real_global_success": ok(glob), "amcl_real_track_success": ok(track)}
    for name, (ref, _) in results.items():
        tr, gl = runs("track", (name,)), runs("global", (name,))
        keys[f"{name}_slam_trans_mean_m"] = f"{ref.trans_mean_m:.4f}"
        keys[f"{name}_track_trans_mean_m"] = mean([r.trans_mean_m for r in tr])
        keys[f"{name}_track_trans_tracked_m"] = mean([r.trans_tracked_m for r in tr
                                                      if math.isfinite(r.trans_tracked_m)])
        keys[f"{name}_track_abs_p95_m"] = mean([r.abs_p95_m for r in tr], ".3f")
        keys[f"{name}_track_converge_s"] = median([r.converge_s for r in tr])
        keys[f"{name}_track_success"] = ok(tr)
        keys[f"{name}_global_converge_s"] = median([r.converge_s for r in gl])
        keys[f"{name}_global_success"] = ok(gl)
    return " ".join(f"{k}={v}" for k, v in keys.items())


def parse_sets(items: list[str]) -> dict:
    """``KEY=VALUE`` strings -> {KEY: VALUE as YAML reads it} (numbers, booleans, strings)."""
    out = {}
    for kv in items:
        k, sep, v = kv.partition("=")
        if not sep:
            raise SystemExit(f"--set wants KEY=VALUE, got {kv!r}")
        out[k] = yaml.safe_load(v)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--datasets", nargs="+", default=["intel", "aces"], choices=sorted(LASER_MAX_RANGE_M))
    ap.add_argument("--seeds", type=int, default=5, help="global localisation runs per log (default 5)")
    ap.add_argument("--track-seeds", type=int, default=2,
                    help="seeds per tracking start; 4 starts (1 m / 30 deg off) each (default 2: 8 runs per log)")
    ap.add_argument("--quick", action="store_true", help=f"only the first {QUICK_SCANS} scans of each log "
                    "(its own SLAM map; a smoke run)")
    ap.add_argument("--out", default="/tmp/zenav_bench_amcl_real", help="SLAM map and trajectory cache")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override an amcl parameter, e.g. --set max_particles=20000 (the README names every "
                         "override its figures use)")
    ap.add_argument("--odom-noise", choices=("ros", "measured"), default="ros",
                    help="ros: ROS amcl's default odom_alpha1..4 (0.2); measured: fitted to the log's odometry "
                         f"against SLAM's trajectory on its first {MEASURE_SHARE * 100:.0f} %% "
                         "(zenav slam odom-noise), "
                         "as a user calibrates a robot")
    ap.add_argument("--laser-noise", choices=("ros", "measured"), default="ros",
                    help="ros: ROS amcl's default laser_sigma_hit (0.2 m); measured: fitted to the scans' end "
                         f"points seen from SLAM's trajectory against its map, on the first {MEASURE_SHARE * 100:.0f} "
                         "%% of the log (zenav slam laser-noise)")
    ap.add_argument("--refine", action="store_true",
                    help="zenav's refine_pose: every scan, the pose is refined by a local search of that scan's "
                         "likelihood on the map (master_side/localization/refine.py)")
    a = ap.parse_args(argv)
    sets = parse_sets(a.set)
    if a.refine:
        sets = {"refine_pose": True, **sets}
    t0 = time.perf_counter()
    results = {}
    for name in a.datasets:
        ref, rows = bench_log(name, QUICK_SCANS if a.quick else None, a.seeds, a.track_seeds, Path(a.out), sets,
                              odom_noise=a.odom_noise, laser_noise=a.laser_noise)
        results[name] = (ref, rows)
        print_table(name, ref, rows, len(ref.stamps), ref.stamps[-1] - ref.stamps[0])
    print(f"\nwall {time.perf_counter() - t0:.0f} s, cpu {time.process_time():.0f} s"
          + (f"; amcl overrides {sets}" if sets else ""))
    print(summary_line(results) + f" odom_noise={a.odom_noise} laser_noise={a.laser_noise} "
          f"refine_pose={'on' if sets.get('refine_pose') else 'off'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
