"""MRPB's static environments and their start/goal tests (``../shared/datasets/mrpb``).

Each environment's ``map10cm/<env>/config.txt`` gives its tests as launch-file snippets
(``initial_pose_x/y/a``, ``goal_pose_x/y/a``; map frame, metres and radians). MRPB has each map twice, at
0.1 m (``map10cm/``) and at 0.05 m (``maps/``), in the same frame. The finer set is used, for the world and
for the robot's map: rasterised from the same Gazebo worlds, the 0.1 m cells thicken every wall by up to
a cell (an occupied 0.1 m cell holds two occupied 0.05 m cells on average), which narrows the benchmark's
0.6 m passages to what the P3-AT (0.51 m wide) cannot pass, and they bound AMCL's likelihood field to
0.1 m steps. The simulated world is the map (walls as obstacles at its cells). In the
``*_partially_unknown`` environments the robot is given that map, in which some obstacles are unknown,
while the world is the full map of the same place (its occupied cells are a superset: ``world_map``), so
the obstacle layer must find what the map lacks.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

# the static environments (the *_dynamic ones and six_people have pedestrians: no static world)
STATIC_ENVS = ("maze", "narrow_graph", "office01add", "office02", "office02_partially_unknown", "room02",
               "shopping_mall", "shopping_mall_partially_unknown", "track")
_ARG = re.compile(r'<arg\s+name="(\w+)"\s+default="([^"]+)"\s*/>')
_KEYS = ("initial_pose_x", "initial_pose_y", "initial_pose_a", "goal_pose_x", "goal_pose_y", "goal_pose_a")
Pose = tuple[float, float, float]


@dataclass(frozen=True)
class Case:
    env: str
    test: int  # 1-based, as config.txt numbers them
    start: Pose  # x, y, yaw in the map frame
    goal: Pose
    map_file: Path  # the map the robot is given
    world_file: Path  # the map the simulator is built from

    @property
    def name(self) -> str:
        return f"{self.env}/{self.test}"


MAPS = "maps"  # the 0.05 m set, beside map10cm/ (which holds the tests)


def world_map(root: Path, env: str) -> Path:
    """The full map of ``env``'s place: a partially unknown environment's world is its known twin."""
    return root.parent / MAPS / env.removesuffix("_partially_unknown") / "map.yaml"


def robot_map(root: Path, env: str) -> Path:
    """The map the robot is given."""
    return root.parent / MAPS / env / "map.yaml"


def parse_config(text: str, source: str = "config.txt") -> list[tuple[Pose, Pose]]:
    """The tests of one config.txt: [(start (x, y, a), goal (x, y, a)), ...] in the file's order."""
    tests: list[tuple[Pose, Pose]] = []
    cur: dict[str, float] = {}
    for name, value in _ARG.findall(text):
        cur[name] = float(value)
        if all(k in cur for k in _KEYS):
            x, y, a, gx, gy, ga = (cur[k] for k in _KEYS)
            tests.append(((x, y, a), (gx, gy, ga)))
            cur = {}
    if cur:
        raise ValueError(f"{source}: an incomplete test (has {sorted(cur)})")
    if not tests:
        raise ValueError(f"{source}: no test found")
    return tests


def load_cases(root: Path, envs: tuple[str, ...] = STATIC_ENVS, tests: tuple[int, ...] = ()) -> list[Case]:
    """Every test of ``envs`` (only those numbered in ``tests``, if given); ``root`` is MRPB's map10cm/."""
    out = []
    for env in envs:
        cfg = root / env / "config.txt"
        if not cfg.exists():
            raise FileNotFoundError(f"{cfg}: no such MRPB environment (known: {', '.join(STATIC_ENVS)})")
        for i, (start, goal) in enumerate(parse_config(cfg.read_text(), str(cfg)), 1):
            if not tests or i in tests:
                out.append(Case(env, i, start, goal, robot_map(root, env), world_map(root, env)))
    return out


TIME_LIMIT_S = 300.0  # simulated seconds from the goal: ours (MRPB names none); its longest case is 38 m


@dataclass
class Result:
    """One case driven to its end: ``status`` success (move_base reached the goal, no contact), collision
    (the run ends at the first contact), aborted (move_base gave up) or timeout (``TIME_LIMIT_S``)."""
    case: Case
    status: str
    reason: str
    trace: np.ndarray  # rows (t, x, y, yaw, v, w) of ground truth, one per control cycle, from the goal
    cycle_ms: np.ndarray  # move_base's control cycles (wall time, ms)
    wall_s: float
    loc_err: np.ndarray | None = None  # the localiser's position error (m) over the run; None: exact TF

    @property
    def success(self) -> bool:
        return self.status == "success"
