"""The fast mode stands for the real stack: one BARN world, the same seed, run in one process
(``deploy.barn.inproc``: the nodes' pieces built from the YAML by the agents' loaders, stepped on one
clock) and over the bus (``zenav robot`` + ``zenav master`` + ``zenav goal``, separate processes), gives the
same path and the same commands along it.

Not bit for bit: on the bus the nodes run asynchronously (a scan reaches the costmap a few ms after its
stamp, a control cycle reads whatever costmap is there), so commands differ in the last digits and the
bus run's clock starts earlier. On world 23 the two paths lie within 5 cm of each other and the commanded
speed along the path differs by 0.02 m/s on average (0.08 rad/s in turn rate); the bounds below are
several times that, and far below what a different parameter (a speed limit, an inflation radius) or a
differently wired costmap would change. (This is also the fast mode's own test on a BARN world.)

The bus run's simulator runs at half real time. At real time, on a 2-core machine the suite loads to an
average of 10, move_base's commands came late enough for the robot to hold old ones and the bus run
took 9.6 s against the fast mode's 6.5 s. Whether the stack keeps up in real time is a benchmark's
figure (``bench/barn.py --mode bus``); this test is about the same behaviour, so it gives the processes
the time of a less loaded machine."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from deploy.barn import rules as barn
from deploy.barn.bus import run_world_bus
from deploy.barn.inproc import ROBOT_CONFIG, BarnStack
from robot_side.worlds.barn import GOAL

MASTER = Path(__file__).resolve().parents[2] / "master_side" / "config" / "jackal_barn_zenav.yaml"
WORLD, SEED = 23, 23


def _along_path(trace: np.ndarray, cmds: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Commanded v and w as functions of the distance driven (the runs' clocks differ, their paths not)."""
    driven = np.r_[0.0, np.cumsum(np.hypot(np.diff(trace[:, 1]), np.diff(trace[:, 2])))]
    at = np.interp(cmds[:, 0], trace[:, 0], driven)
    order = np.argsort(at, kind="stable")
    return np.interp(s, at[order], cmds[order, 1]), np.interp(s, at[order], cmds[order, 2])


@pytest.mark.slow
def test_fast_mode_and_bus_mode_drive_the_same_path_with_the_same_commands(tmp_path):
    fast = BarnStack(barn.write_world(WORLD, tmp_path), ROBOT_CONFIG, MASTER, seed=SEED).run(WORLD, GOAL)
    bus = run_world_bus(WORLD, tmp_path, master_config=MASTER, seed=SEED, speed=0.5)
    assert fast.run.success and not fast.run.collision, fast.events[-10:]
    assert len(fast.cycle_ms) > 20 and fast.sim_s < barn.TIME_LIMIT_S
    assert bus["run"].success and not bus["run"].collision, bus["note"]
    assert bus["run"].time_s == pytest.approx(fast.run.time_s, rel=0.15)

    ft, bt = fast.trace, bus["trace"]
    gap = max(cKDTree(ft[:, 1:]).query(bt[:, 1:])[0].max(), cKDTree(bt[:, 1:]).query(ft[:, 1:])[0].max())
    assert gap < 0.25, f"the paths part by {gap:.2f} m"

    assert len(bus["cmds"]) > 50 and len(fast.cmds) > 50
    length = min(np.hypot(*np.diff(t[:, 1:], axis=0).T).sum() for t in (ft, bt))
    s = np.linspace(0.2, length - 0.2, 200)
    fv, fw = _along_path(ft, fast.cmds, s)
    bv, bw = _along_path(bt, bus["cmds"], s)
    assert np.abs(fv - bv).mean() < 0.15, f"v differs by {np.abs(fv - bv).mean():.3f} m/s on average"
    assert np.abs(fw - bw).mean() < 0.3, f"w differs by {np.abs(fw - bw).mean():.3f} rad/s on average"
