"""Kümmerle et al. (2009) relations metric: compare relative motions of an estimate with ground truth.

For each relation (t1, t2, δ_gt): δ_est = P(t1)⁻¹ ⊕ P(t2), ε = δ_gt⁻¹ ⊕ δ_est; statistics of
|trans(ε)| (m) and |rot(ε)| (deg), absolute and squared.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.argtypes import positive
from common.geometry import Pose2D


@dataclass(frozen=True)
class Relation:
    t1: float
    t2: float
    delta: Pose2D


@dataclass(frozen=True)
class Metric:
    trans: np.ndarray  # |trans(ε)| per used relation, m
    rot: np.ndarray  # |rot(ε)| per used relation, rad
    missing: int  # relations whose timestamps had no pose

    def summary(self) -> dict[str, float]:
        t, r = self.trans, np.degrees(self.rot)
        return {"trans_mean_m": float(t.mean()), "trans_std_m": float(t.std()),
                "rot_mean_deg": float(r.mean()), "rot_std_deg": float(r.std()),
                "trans2_mean_m2": float((t**2).mean()), "trans2_std_m2": float((t**2).std()),
                "rot2_mean_deg2": float((r**2).mean()), "rot2_std_deg2": float((r**2).std()),
                "trans_median_m": float(np.median(t)), "relations": len(t)}


class InputError(ValueError):
    """A relations or trajectory file that cannot be read: names the file and the line."""


def _rows(path: str | Path, width: int, what: str) -> list[list[float]]:
    """The first ``width`` numbers of every non-empty, non-comment line of ``path``."""
    try:
        text = Path(path).read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read the {what}: {getattr(e, 'strerror', None) or e}") from None
    rows = []
    for n, line in enumerate(text.splitlines(), 1):
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        try:
            v = [float(x) for x in f[:width]]
        except ValueError:
            v = []
        if len(v) < width or not all(np.isfinite(v)):
            raise InputError(f"{path}:{n}: not a {what} line (needs {width} numbers): {line[:60]!r}")
        rows.append(v)
    if not rows:
        raise InputError(f"{path}: no {what} lines")
    return rows


def read_relations(path: str | Path) -> list[Relation]:
    """``t1 t2 x y z roll pitch yaw`` per line (``#`` comments allowed)."""
    return [Relation(v[0], v[1], Pose2D(v[2], v[3], v[7])) for v in _rows(path, 8, "relations")]


def read_trajectory(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``timestamp x y theta`` lines -> (stamps (N,), poses (N, 3)) sorted by stamp."""
    a = np.array(_rows(path, 4, "trajectory"), float).reshape(-1, 4)
    a = a[np.argsort(a[:, 0], kind="stable")]
    return a[:, 0], a[:, 1:]


def _lookup(stamps: np.ndarray, t: float, tol: float) -> int | None:
    i = int(np.searchsorted(stamps, t))
    best = None
    for j in (i - 1, i):
        if not (0 <= j < len(stamps)) or abs(stamps[j] - t) > tol:
            continue
        if best is None or abs(stamps[j] - t) < abs(stamps[best] - t):
            best = j
    return best


def evaluate(stamps: np.ndarray, poses: np.ndarray, relations: list[Relation], tol: float = 1e-3) -> Metric:
    """Errors of every relation whose two stamps have a pose within ``tol`` seconds."""
    trans, rot, missing = [], [], 0
    for rel in relations:
        i, j = _lookup(stamps, rel.t1, tol), _lookup(stamps, rel.t2, tol)
        if i is None or j is None:
            missing += 1
            continue
        est = Pose2D(*poses[i]).between(Pose2D(*poses[j]))
        err = rel.delta.inverse().compose(est)
        trans.append(np.hypot(err.x, err.y))
        rot.append(abs(err.theta))
    if not trans:
        raise ValueError("no relation matched the trajectory's timestamps")
    return Metric(np.array(trans), np.array(rot), missing)


def format_table(m: Metric) -> str:
    s = m.summary()
    lines = [f"{'':10} {'mean':>12} {'std':>12}",
             f"{'trans m':10} {s['trans_mean_m']:12.4f} {s['trans_std_m']:12.4f}",
             f"{'trans m2':10} {s['trans2_mean_m2']:12.5f} {s['trans2_std_m2']:12.5f}",
             f"{'rot deg':10} {s['rot_mean_deg']:12.3f} {s['rot_std_deg']:12.3f}",
             f"{'rot deg2':10} {s['rot2_mean_deg2']:12.3f} {s['rot2_std_deg2']:12.3f}",
             f"median trans {s['trans_median_m']:.4f} m; relations used {s['relations']}, "
             f"missing {m.missing}",
             f"trans_mean_m={s['trans_mean_m']:.4f} trans_std_m={s['trans_std_m']:.4f} "
             f"rot_mean_deg={s['rot_mean_deg']:.3f} rot_std_deg={s['rot_std_deg']:.3f} "
             f"relations={s['relations']}"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="zenav slam eval", description="Kümmerle relations metric")
    ap.add_argument("--relations", required=True, help="ground-truth relations file")
    ap.add_argument("trajectory", help="trajectory.txt (timestamp x y theta)")
    ap.add_argument("--tolerance", type=positive, default=1e-3, help="timestamp match tolerance (s)")
    a = ap.parse_args(argv)
    try:
        stamps, poses = read_trajectory(a.trajectory)
        relations = read_relations(a.relations)
    except InputError as e:
        print(f"zenav slam eval: {e}", file=sys.stderr)
        return 2
    try:
        m = evaluate(stamps, poses, relations, a.tolerance)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(format_table(m))
    return 0
