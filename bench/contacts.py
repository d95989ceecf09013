"""Why each contact of an exploration run or an MRPB case happened, from its snapshot (`python
bench/explore.py` and `python bench/mrpb.py --mode bus` leave `<run dir>/contacts/contact_<n>.npz`: the local
costmaps of the 3 s before, the odometry and true poses). Give `--master` the file the run used (MRPB's:
master_side/config/p3at_zenav.yaml): its local costmap's footprint padding decides "erased by footprint
clearing".

For each contact: the part of the robot that touched (front, rear, a flank, a corner: the touched point in
the robot's true frame) and the history of the touched point in the local costmap, map by map (the point
placed in the odometry frame as the planner saw it), with one of these verdicts:

- `marked until the contact`: the planner had the obstacle and drove into it anyway (planner, controller
  or odometry: the costmap knew);
- `erased by footprint clearing`: marked, then freed while it lay inside the padded footprint (the layer
  frees the cells under the robot: a mark within the padding beside the body goes too);
- `cleared, not under the footprint`: marked, then freed elsewhere (a ray through it, the window moving);
- `never marked`: no sensor had put it in the costmap in those 3 s (seen by nothing, or too late).

Each goal move_base aborted (`abort_<n>.npz`) is listed after the contacts with move_base's reason and
what boxed the robot in on the last local costmap before it: the nearest mark to each part of the bare
outline (front, rear, each flank, each corner), e.g. a wall 0.10 m off the left flank and one 0.14 m beyond
the nose: no turn and no forward arc is free.

  python bench/contacts.py RUN_DIR [RUN_DIR ...] [--master master_side/config/p3at_slam_zenav.yaml]
  python bench/contacts.py MRPB_WORKDIR/zenav/CASE --master master_side/config/p3at_zenav.yaml

Ends with contacts=… contacts_marked=… contacts_footprint_cleared=… contacts_cleared=… contacts_never_marked=…
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from common.geometry import Pose2D, distance_to_outline, points_in_polygon  # noqa: E402
from deploy.mrpb.contacts import nearest_mark  # noqa: E402
from master_side.costmap.cost_values import LETHAL  # noqa: E402
from master_side.costmap.footprint import pad_footprint  # noqa: E402

MASTER = ROOT / "master_side/config/p3at_slam_zenav.yaml"
VERDICTS = ("marked", "footprint_cleared", "cleared", "never_marked")


def local_footprint(master: Path) -> tuple[np.ndarray, float]:
    """The local costmap's padded footprint (robot frame) and its padding, from the master file's move_base."""
    from master_side import agent as master_agent
    from master_side.move_base.config import load_move_base_config

    launch = master_agent.load(str(master))  # as the agent reads it: includes, relative files
    lc = load_move_base_config(*launch.node_params(launch.entry("move_base"))).local_costmap
    return np.asarray(lc.footprint, float), float(lc.costmap.footprint_padding)


def _pose_at(rows: np.ndarray, t: float) -> Pose2D:
    return Pose2D(*rows[int(np.argmin(np.abs(rows[:, 0] - t))), 1:4])


def part_of(bare: np.ndarray, local: np.ndarray) -> str:
    """Which part of the robot's outline a point in its frame is nearest to."""
    x, y = local
    front, rear = x > 0.8 * bare[:, 0].max(), x < 0.8 * bare[:, 0].min()
    side = "left" if y > 0 else "right"
    flank = abs(y) > 0.8 * np.abs(bare[:, 1]).max()
    if (front or rear) and flank:
        return f"{'front' if front else 'rear'}-{side} corner"
    if front or rear:
        return "front" if front else "rear"
    return f"{side} flank"


def diagnose(snap, padded: np.ndarray, padding: float) -> tuple[str, str, list[tuple[float, float]]]:
    """(verdict, what it says, [(seconds before the contact, distance to the nearest mark)] per map)."""
    point, stamp, res = np.asarray(snap["point"], float), float(snap["stamp"]), float(snap["resolution"])
    odom, truth = np.asarray(snap["odom"]), np.asarray(snap["truth"])
    near = 1.5 * res  # the touched point's own cell or the next one
    history, inside = [], []
    for data, t, (ox, oy) in zip(snap["maps"], snap["map_stamps"], snap["origins"]):
        od, tr = _pose_at(odom, t), _pose_at(truth, t)
        px, py = od.compose(tr.inverse()).apply(point[None, :])[0]  # world -> odometry frame at that time
        history.append((float(t) - stamp, nearest_mark(data, (ox, oy), res, px, py)))
        fp = od.apply(padded)
        inside.append(bool(points_in_polygon(np.array([px]), np.array([py]), fp)[0]))
    marked = [d <= near for _, d in history]
    before = [k for k, (dt, _) in enumerate(history) if dt <= 0.0]
    if not any(marked):
        return "never_marked", "never marked in the local costmap", history
    if before and marked[before[-1]]:
        return "marked", f"marked until the contact ({history[before[-1]][0]:+.1f} s)", history
    last = max(k for k, m in enumerate(marked) if m)
    gone = last + 1 if last + 1 < len(history) else last
    when = history[gone][0]
    if inside[gone]:
        return ("footprint_cleared", f"marked until {history[last][0]:+.1f} s, freed at {when:+.1f} s while inside "
                f"the padded footprint (padding {padding:.2f} m)", history)
    said = f"marked until {history[last][0]:+.1f} s, freed at {when:+.1f} s, not under the footprint"
    return "cleared", said, history


def boxed_in(snap, bare: np.ndarray, reach: float = 0.5) -> dict[str, float]:
    """Part of the robot -> distance from the bare outline to the nearest LETHAL cell centre beside that part
    (within ``reach``), on the snapshot's last local costmap with the robot at its odometry pose then."""
    data, (ox, oy), res = snap["maps"][-1], snap["origins"][-1], float(snap["resolution"])
    rows, cols = np.nonzero(np.asarray(data) == LETHAL)
    pose = _pose_at(np.asarray(snap["odom"]), float(snap["map_stamps"][-1]))
    cells = np.column_stack((ox + (cols + 0.5) * res, oy + (rows + 0.5) * res))
    local = pose.inverse().apply(cells) if len(cells) else cells
    dist = distance_to_outline(local, bare) if len(local) else np.zeros(0)
    out: dict[str, float] = {}
    for pt, d in zip(local[dist <= reach], dist[dist <= reach]):
        part = part_of(bare, pt)
        out[part] = min(out.get(part, np.inf), float(d))
    return dict(sorted(out.items(), key=lambda kv: kv[1]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path, help="run directories (or their contacts/ directories)")
    ap.add_argument("--master", type=Path, default=MASTER, help="master file whose local costmap footprint to use")
    args = ap.parse_args(argv)
    padded, padding = local_footprint(args.master)
    bare = pad_footprint(padded, -padding)
    files = []
    for r in args.runs:
        d = r if r.name == "contacts" else r / "contacts"
        files += sorted(d.glob("contact_*.npz"), key=lambda p: int(p.stem.split("_")[1]))
    if not files:
        print(f"no contact snapshots under {', '.join(map(str, args.runs))}", file=sys.stderr)
    counts: Counter = Counter()
    print(f"{'contact':<40} {'part':<18} verdict")
    for f in files:
        with np.load(f) as snap:
            verdict, said, history = diagnose(snap, padded, padding)
            tr = _pose_at(np.asarray(snap["truth"]), float(snap["stamp"]))
            part = part_of(bare, tr.inverse().apply(np.asarray(snap["point"], float)[None, :])[0])
        counts[verdict] += 1
        print(f"{str(f.relative_to(f.parents[2]) if len(f.parents) > 2 else f):<40} {part:<18} {said}")
        print("    " + "  ".join(f"{dt:+.1f}s:{'-' if d == float('inf') else f'{d:.2f}'}" for dt, d in history[::3]))
    aborts = []
    for r in args.runs:
        d = r if r.name == "contacts" else r / "contacts"
        aborts += sorted(d.glob("abort_*.npz"), key=lambda p: int(p.stem.split("_")[1]))
    for f in aborts:
        with np.load(f) as snap:
            near = boxed_in(snap, bare)
            print(f"{str(f.relative_to(f.parents[2]) if len(f.parents) > 2 else f):<40} {snap['reason']}")
        print("    nearest marks: " + (", ".join(f"{p} {d:.2f} m" for p, d in near.items()) or "none within 0.5 m"))
    print(f"contacts={len(files)} " + " ".join(f"contacts_{v}={counts[v]}" for v in VERDICTS)
          + f" aborts={len(aborts)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
