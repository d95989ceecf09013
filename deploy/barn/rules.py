"""BARN benchmark pieces: the training worlds of ``../shared/datasets/barn`` and the challenge's verdict.

Pure (numpy; no bus): a benchmark script runs ``zenav robot --config robot_side/config/jackal_sim.yaml
--world <write_world(i, dir)>`` + the master + ``zenav goal``, records the simulator's ``ground_truth``
and ``collision`` topics, and judges the run here, with the rules of the challenge's ``run.py``
(github Daffan/the-barn-challenge, as ``../shared/datasets/barn/README.md`` states them):

- the run's clock starts when the robot is 0.1 m from its start (start of motion);
- it succeeds when the robot comes within 1 m of the goal without any collision, within 100 s of
  simulated time; a collision fails it (even at the goal), then a timeout;
- score = success x OT / clip(AT, 2 OT, 8 OT), AT the run's time, OT = L / 2.0 m/s, L the reference
  path length.

    python -m deploy.barn.rules write 1 --out /tmp/barn          # /tmp/barn/barn_1.yaml
    python -m deploy.barn.rules lengths                          # L of every training world
"""

from __future__ import annotations

import argparse
import functools
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robot_side.worlds.barn import GOAL, RESOLUTION, START, barn_world_spec, reference_path_length, write_world_yaml

__all__ = ["TIME_LIMIT_S", "GOAL_RADIUS_M", "MOTION_START_M", "MAX_SPEED", "shared_dir", "dataset_dir",
           "training_worlds", "load_cylinders", "load_path", "reference_length", "optimal_time", "write_world",
           "score", "Run", "judge", "held_to_time_limit", "Summary", "summarize", "trace_from_odometry",
           "collision_times"]

REPO = Path(__file__).resolve().parents[2]
TIME_LIMIT_S = 100.0    # s of simulated time from the start of motion
GOAL_RADIUS_M = 1.0     # success: within this distance of the goal
MOTION_START_M = 0.1    # the run's clock starts when the robot is this far from its start
MAX_SPEED = 2.0         # m/s: the optimal time OT = L / MAX_SPEED


# ---------------------------------------------------------------------- dataset
def shared_dir() -> Path:
    """``$ZENAV_SHARED`` or ``<repo>/../shared`` (as tests/conftest.py)."""
    return Path(os.environ.get("ZENAV_SHARED", REPO.parent / "shared")).resolve()


def dataset_dir() -> Path:
    return shared_dir() / "datasets" / "barn"


@functools.lru_cache(maxsize=4)
def _npz(path: Path) -> dict[str, np.ndarray]:
    if not path.is_file():
        raise FileNotFoundError(f"BARN data not found: {path} (set ZENAV_SHARED)")
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def _arrays(name: str) -> dict[str, np.ndarray]:
    return _npz(dataset_dir() / name)


def _get(name: str, i: int) -> np.ndarray:
    arrays = _arrays(name)
    key = f"world_{int(i)}"
    if key not in arrays:
        raise KeyError(f"world {i} is not a BARN training world (N % 6 != 0, 1..299)")
    return arrays[key]


def training_worlds() -> list[int]:
    """Indices of the 250 training worlds (every N with N % 6 != 0)."""
    return sorted(int(k.split("_")[1]) for k in _arrays("cylinders_train.npz"))


def load_cylinders(i: int) -> np.ndarray:
    """(K, 2) float64 cylinder centres (m, world frame) of world ``i``, the 96 box cylinders included."""
    return _get("cylinders_train.npz", i).astype(np.float64)


def load_path(i: int) -> np.ndarray:
    """(n, 2) int64 reference path cells (r, c) of the 30 x 30 BARN grid of world ``i``."""
    return _get("paths_train.npz", i).astype(np.int64)


def reference_length(i: int) -> float:
    """L of world ``i``: start -> path cells -> goal (m)."""
    return reference_path_length(load_path(i))


def optimal_time(length_m: float) -> float:
    """OT = L / 2.0 m/s."""
    return float(length_m) / MAX_SPEED


def write_world(i: int, directory: str | Path, name: str | None = None, resolution: float = RESOLUTION,
                comment: str = "") -> Path:
    """Write world ``i`` as a simulator world YAML ``<directory>/<name or barn_i>.yaml``; returns its path."""
    name = name or f"barn_{int(i)}"
    spec = barn_world_spec(load_cylinders(i), name=name, resolution=resolution)
    comment = comment or (
        f"BARN training world {int(i)} (../shared/datasets/barn/cylinders_train.npz, key world_{int(i)}: "
        f"{len(spec['cylinders'])} cylinders,\nthe 96 of the box included), reference path length "
        f"L = {reference_length(i):.3f} m. Made with\n  python -m deploy.barn.rules write {int(i)} --out DIR"
        f"{'' if name == f'barn_{int(i)}' else f' --name {name}'}\n(robot_side/worlds/barn.py: "
        f"barn_world_spec + write_world_yaml; start and goal as the BARN challenge).")
    return write_world_yaml(spec, Path(directory) / f"{name}.yaml", comment)


# ---------------------------------------------------------------------- verdict
def score(success: bool, time_s: float, optimal_time_s: float) -> float:
    """success x OT / clip(AT, 2 OT, 8 OT)."""
    if not success:
        return 0.0
    return float(optimal_time_s / np.clip(time_s, 2.0 * optimal_time_s, 8.0 * optimal_time_s))


@dataclass(frozen=True)
class Run:
    """The verdict on one run. ``time_s`` (AT) runs from the start of motion to the end of the run."""

    world: int
    success: bool
    collision: bool
    timeout: bool
    time_s: float
    optimal_time_s: float
    score: float
    motion_start_s: float       # sim time the robot was 0.1 m from its start (nan: it never moved)
    goal_distance_m: float      # distance to the goal at the end of the run

    @property
    def status(self) -> str:
        return "collided" if self.collision else "timeout" if self.timeout else "succeeded"


def judge(world: int, trace: np.ndarray | Sequence, collisions: Iterable[float] = (),
          optimal_time_s: float | None = None, start: Sequence[float] = START[:2],
          goal: Sequence[float] = GOAL) -> Run:
    """Judge a run from its ground truth.

    ``trace``: (N, 3) rows (t, x, y), sim time increasing, robot position in the world frame (the
    simulator's ``ground_truth``); ``collisions``: sim times of collisions (``collision_times``);
    ``optimal_time_s``: OT (default: from ``reference_length(world)``). The run ends at the first sample
    after the start of motion where the robot is within 1 m of the goal, has collided, or 100 s have
    passed; a collision outranks a timeout, which outranks success (as run.py). A robot that never moved
    times out once the trace spans 100 s. A trace that ends earlier without a verdict raises ValueError.
    """
    tr = np.asarray(trace, dtype=np.float64).reshape(-1, 3)
    if len(tr) == 0:
        raise ValueError("empty trace")
    if np.any(np.diff(tr[:, 0]) < 0):
        raise ValueError("trace times must not decrease")
    hits = np.sort(np.asarray(list(collisions), dtype=np.float64))
    ot = optimal_time(reference_length(world)) if optimal_time_s is None else float(optimal_time_s)
    t, x, y = tr[:, 0], tr[:, 1], tr[:, 2]
    to_goal = np.hypot(x - goal[0], y - goal[1])
    moved = np.flatnonzero(np.hypot(x - start[0], y - start[1]) >= MOTION_START_M)

    def run(k: int, t0: float, elapsed: float, collided: bool, timed_out: bool) -> Run:
        success = not collided and not timed_out
        return Run(int(world), success, collided, timed_out and not collided, float(elapsed), ot,
                   score(success, elapsed, ot), t0, float(to_goal[k]))

    if len(moved) == 0:  # never moved: only a collision or the time limit can end the run
        if len(hits) and hits[0] <= t[-1]:
            k = int(np.searchsorted(t, hits[0]))
            return run(k, math.nan, t[k] - t[0], True, False)
        if t[-1] - t[0] >= TIME_LIMIT_S:
            k = int(np.searchsorted(t, t[0] + TIME_LIMIT_S))
            return run(k, math.nan, t[k] - t[0], False, True)
        raise ValueError(f"the robot never moved and the trace spans only {t[-1] - t[0]:.1f} s")
    k0 = int(moved[0])
    t0 = float(t[k0])
    n_hits = np.searchsorted(hits, t[k0:], side="right")   # collisions up to each sample
    elapsed = t[k0:] - t0
    done = (to_goal[k0:] <= GOAL_RADIUS_M) | (n_hits > 0) | (elapsed >= TIME_LIMIT_S)
    if not done.any():
        raise ValueError(f"the trace ends {elapsed[-1]:.1f} s after the start of motion without a verdict")
    j = int(np.argmax(done))
    return run(k0 + j, t0, elapsed[j], bool(n_hits[j] > 0), bool(elapsed[j] >= TIME_LIMIT_S))


def held_to_time_limit(trace: np.ndarray, start: Sequence[float] = START) -> np.ndarray:
    """A trace that ended without a verdict (move_base gave up, the robot never started), extended as
    BARN's run.py sees it: the robot stays where it is until the time limit after its start of motion (or
    after the trace's first sample if it never moved)."""
    tr = np.asarray(trace, dtype=np.float64).reshape(-1, 3)
    moved = np.flatnonzero(np.hypot(tr[:, 1] - start[0], tr[:, 2] - start[1]) >= MOTION_START_M)
    end = (tr[moved[0], 0] if len(moved) else tr[0, 0]) + TIME_LIMIT_S
    return np.vstack((tr, [max(end, tr[-1, 0]), tr[-1, 1], tr[-1, 2]]))


def trace_from_odometry(msgs: Iterable) -> np.ndarray:
    """(N, 3) rows (stamp, x, y) from ``ground_truth`` Odometry messages, sorted by stamp."""
    rows = [(m.header.stamp, m.pose2d.x, m.pose2d.y) for m in msgs]
    arr = np.array(rows, dtype=np.float64).reshape(-1, 3)
    return arr[np.argsort(arr[:, 0], kind="stable")]


def collision_times(msgs: Iterable) -> list[float]:
    """Stamps of the ``collision`` messages that report a new collision (their count went up)."""
    out, last = [], 0
    for m in sorted(msgs, key=lambda m: m.header.stamp):
        if m.count > last:
            out.append(float(m.header.stamp))
            last = m.count
    return out


@dataclass(frozen=True)
class Summary:
    runs: int
    success_rate: float
    collision_rate: float
    timeout_rate: float
    mean_time_success_s: float   # nan without a successful run
    mean_score: float

    def line(self) -> str:
        """One ``key=value`` line (bench convention)."""
        return (f"runs={self.runs} success={self.success_rate:.3f} collision={self.collision_rate:.3f} "
                f"timeout={self.timeout_rate:.3f} time_success_s={self.mean_time_success_s:.2f} "
                f"score={self.mean_score:.4f}")


def summarize(runs: Sequence[Run]) -> Summary:
    """Rates over all runs, mean time of the successful ones, mean score (the benchmark's score)."""
    n = len(runs)
    if n == 0:
        return Summary(0, math.nan, math.nan, math.nan, math.nan, math.nan)
    ok = [r.time_s for r in runs if r.success]
    return Summary(n, sum(r.success for r in runs) / n, sum(r.collision for r in runs) / n,
                   sum(r.timeout for r in runs) / n, float(np.mean(ok)) if ok else math.nan,
                   float(np.mean([r.score for r in runs])))


# ---------------------------------------------------------------------- command line
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m deploy.barn.rules", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write", help="write training worlds as simulator world YAMLs")
    w.add_argument("worlds", nargs="*", type=int, help="world indices (default: all training worlds)")
    w.add_argument("--out", required=True, help="output folder")
    w.add_argument("--name", help="file / world name (one world only)")
    sub.add_parser("lengths", help="print the reference path length L of every training world")
    a = ap.parse_args(argv)
    if a.cmd == "write":
        worlds = a.worlds or training_worlds()
        if a.name and len(worlds) != 1:
            ap.error("--name needs exactly one world")
        for i in worlds:
            print(write_world(i, a.out, a.name))
    else:
        lengths = [(i, reference_length(i)) for i in training_worlds()]
        for i, length in lengths:
            print(f"world_{i} L={length:.3f} m OT={optimal_time(length):.3f} s")
        vals = [v for _, v in lengths]
        print(f"worlds={len(vals)} L_min_m={min(vals):.3f} L_max_m={max(vals):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
