"""One BARN world with the simulated Jackal and zenav's BARN configuration, judged from the simulator's
ground truth by BARN's rule, in the fast mode of ``bench/barn.py`` (deploy/barn/inproc.py: the same nodes'
pieces from the same YAML files, stepped in one process). The way a user runs it over the bus — `zenav
robot`, `zenav master` and `zenav goal` as separate processes — is tested on the same world and
configuration with the MuJoCo engine (tests/sim_mujoco/test_mujoco_barn_bus.py)."""

from __future__ import annotations

from pathlib import Path

from deploy.barn import rules as barn
from deploy.barn.inproc import ROBOT_CONFIG, BarnStack
from robot_side.worlds.barn import GOAL

REPO = Path(__file__).resolve().parents[2]


def test_the_jackal_crosses_a_barn_world_in_the_fast_mode(tmp_path):
    path = barn.write_world(23, tmp_path)
    stack = BarnStack(path, ROBOT_CONFIG, REPO / "master_side" / "config" / "jackal_barn_zenav.yaml", seed=23)
    out = stack.run(23, GOAL)
    assert out.run.success, f"{out.run} {out.final_state}\n" + "\n".join(out.events[-20:])
    assert not out.run.collision
    assert len(out.cycle_ms) > 20 and out.sim_s < barn.TIME_LIMIT_S
