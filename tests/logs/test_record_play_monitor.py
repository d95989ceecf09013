"""Issue 12 acceptance: the simulated P3-AT (`zenav robot` + `zenav master`) drives one short goal
(`zenav goal`) while `zenav record` and `zenav monitor --save A.rrd` run; then `zenav play` of the
recording is watched by `zenav monitor --save B.rrd`. Both Rerun recordings show the same map, scans,
global plan and costmaps, with comparable counts and equal contents at equal stamps."""

from __future__ import annotations

import os
import signal
import uuid
from pathlib import Path

import numpy as np
import pytest
import yaml

from common.bus import Node
from common.messages import Costmap, MoveBaseStatus
from common.zenoh_config import BusConfig
from deploy.logs.mcap_io import read_info
from testkit.nav_stack import MASTER_DIR, ROBOT_CONFIG, NavProc, zenav_command
from tests.monitor.monhelp import has_footer, read_rrd
from tests.support import free_port, wait_until

REPO = Path(__file__).resolve().parents[2]
GOAL = ("-1.3", "0.4", "0.0")  # ~1 m from the room's start (-2.2, 0, 0), clear of the crate
ENTITIES = ("/world/map", "/world/scan", "/world/move_base/global_plan", "/world/global_costmap/costmap",
            "/world/local_costmap/costmap")


def _env(robot: str, listen: int | None, connect: list[int]) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(ZENAV_ROBOT=robot, ZENAV_MULTICAST="0", ZENAV_MODE="peer", PYTHONPATH=str(REPO),
               PYTHONUNBUFFERED="1")
    if listen:
        env["ZENAV_LISTEN"] = f"tcp/127.0.0.1:{listen}"
    if connect:
        env["ZENAV_CONNECT"] = ",".join(f"tcp/127.0.0.1:{p}" for p in connect)
    return env


class Procs:
    def __init__(self, tmp: Path) -> None:
        self.tmp, self.procs = tmp, {}

    def start(self, name: str, args: list[str], env: dict) -> NavProc:
        p = self.procs[name] = NavProc(self.tmp / f"{name}.log", [*zenav_command(), *args], env)
        return p

    def dead(self) -> str:
        return next((f"{n} exited ({p.proc.returncode}):\n{p.log()}" for n, p in self.procs.items()
                     if not p.alive() and n not in ("goal", "play")), "")

    def signal_and_wait(self, names: list[str], sig=signal.SIGINT, timeout: float = 60.0) -> None:
        for n in names:
            self.procs[n].proc.send_signal(sig)
        for n in names:
            assert self.procs[n].proc.wait(timeout) == 0, f"{n}:\n{self.procs[n].log()}"

    def stop_all(self) -> None:
        for p in reversed(list(self.procs.values())):
            p.stop(timeout=10)


def _exact_odometry_robot(tmp: Path) -> Path:
    """The simulated P3-AT of ROBOT_CONFIG with odometry free of noise. The simulator draws odometry
    noise at every 10 ms step, so odom's path is jagged between its 50 Hz samples; a monitor that missed one
    best-effort sample (TF is published best effort) interpolates straight over the jag and draws a scan a
    few millimetres off at a few metres (6.4 mm once in a fresh-clone run, against a 5 mm bound). Without the
    noise odom moves along smooth arcs, a straight interpolation over a missed sample is off by well under
    the bound, and what this test compares, the same scans at the same places, is left to tell."""
    cfg = yaml.safe_load(ROBOT_CONFIG.read_text())
    params = cfg["platform"]["sim"]["params"]
    params["base"] = {**(params.get("base") or {}), "srr": 0.0, "srt": 0.0, "str": 0.0, "stt": 0.0}
    out = tmp / "p3at_sim_exact_odometry.yaml"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


def _grids(rec, entity):
    """stamp -> (cell size, format, data) of every GridMap row."""
    out = {}
    for r in rec[entity]:
        if r.get("GridMap:data") is not None:
            out[r.get("stamp")] = (r["GridMap:cell_size"][0], r["GridMap:format"][0], np.array(r["GridMap:data"][0]))
    return out


@pytest.mark.slow
def test_record_then_play_shows_the_same_scene_in_the_monitor(tmp_path):
    robot = f"rec{uuid.uuid4().hex[:8]}"
    test_port, robot_port, master_port = free_port(), free_port(), free_port()
    everyone = [test_port, robot_port, master_port]
    node = Node("rec_test", config=BusConfig(robot=robot, listen=(f"tcp/127.0.0.1:{test_port}",), multicast=False),
                use_sim_time=False)
    procs = Procs(tmp_path)
    mcap, rrd_a, rrd_b = tmp_path / "run.mcap", tmp_path / "A.rrd", tmp_path / "B.rrd"
    try:
        status = node.subscribe("move_base/status", MoveBaseStatus)
        costmaps = [node.subscribe(f"{n}/costmap", Costmap) for n in ("global_costmap", "local_costmap")]
        procs.start("robot", ["robot", "--config", str(_exact_odometry_robot(tmp_path))],
                    _env(robot, robot_port, [test_port]))
        procs.start("master", ["master", "--config", str(MASTER_DIR / "p3at_known_map.yaml")],
                    _env(robot, master_port, [test_port, robot_port]))
        procs.start("monitor", ["monitor", "--save", str(rrd_a)], _env(robot, None, everyone))
        procs.start("record", ["record", str(mcap), "--progress", "1"], _env(robot, None, everyone))
        wait_until(lambda: (s := status.latest()) is not None and s.reason == "no goal"
                   and all(c.latest() is not None for c in costmaps), 120, "move_base and both costmaps",
                   alive=procs.dead)
        wait_until(lambda: "scan=" in procs.procs["record"].log() and "map=" in procs.procs["record"].log(),
                   60, "the recorder to receive scans and the map", alive=procs.dead)
        goal = procs.start("goal", ["goal", *GOAL, "--timeout", "60"], _env(robot, None, everyone))
        assert goal.proc.wait(90) == 0, goal.log()
        procs.signal_and_wait(["record"], signal.SIGINT)
        procs.signal_and_wait(["monitor"], signal.SIGTERM)
        procs.procs.pop("master").stop()
        procs.procs.pop("robot").stop()
        node.close()
        node = None

        start, end, counts = read_info(mcap)
        for topic in ("scan", "odom", "tf", "tf_static", "map", "cmd_vel", "move_base/global_plan",
                      "global_costmap/costmap", "local_costmap/costmap"):
            assert counts.get(topic), f"nothing recorded on {topic}: {counts}"
        assert 2.0 < end - start < 120, (start, end)  # simulated seconds of the drive

        play_port = free_port()
        procs.start("monitor_b", ["monitor", "--save", str(rrd_b)], _env(robot, play_port, []))
        play = procs.start("play", ["play", str(mcap), "--wait-for", "scan", "--quiet"],
                           _env(robot, None, [play_port]))
        assert play.proc.wait(180) == 0, play.log()
        procs.signal_and_wait(["monitor_b"], signal.SIGTERM)
    finally:
        procs.stop_all()
        if node is not None:
            node.close()

    assert has_footer(rrd_a) and has_footer(rrd_b)
    a, b = read_rrd(rrd_a), read_rrd(rrd_b)
    for e in ENTITIES:
        assert a.get(e) and b.get(e), f"{e}: A {len(a.get(e, []))} rows, B {len(b.get(e, []))} rows"
    span = (int(start * 1e9) - 1, int(end * 1e9) + 1)

    def in_span(rows, component):
        return [r for r in rows if r.get(component) is not None and r.get("stamp") is not None
                and span[0] <= r["stamp"] <= span[1]]

    # Same map, exactly.
    map_a, map_b = _grids(a, "/world/map"), _grids(b, "/world/map")
    (res_a, fmt_a, data_a), (res_b, fmt_b, data_b) = list(map_a.values())[-1], list(map_b.values())[-1]
    assert (res_a, fmt_a) == (res_b, fmt_b) and np.array_equal(data_a, data_b)

    # Scans: comparable counts over the recorded span, equal points at equal stamps.
    rows_a, rows_b = in_span(a["/world/scan"], "Points3D:positions"), in_span(b["/world/scan"], "Points3D:positions")
    # A scan that reaches a monitor before any odometry is drawn in its own frame (Placement; the live monitor's
    # TF subscription can be matched after its scan subscription, on a loaded machine seconds after): those are
    # not the fixed-frame drawing compared here, and they must stay the exception.
    for rows in (rows_a, rows_b):
        placed = [r for r in rows if r.get("CoordinateFrame:frame") == ["odom"]]
        assert len(placed) >= 0.9 * len(rows) - 2, (len(placed), len(rows))
    sa = {r["stamp"]: r["Points3D:positions"] for r in rows_a if r.get("CoordinateFrame:frame") == ["odom"]}
    sb = {r["stamp"]: r["Points3D:positions"] for r in rows_b if r.get("CoordinateFrame:frame") == ["odom"]}
    # The monitor throttles scans on wall time, so a playback slowed by a loaded machine passes more
    # of them than the live run did (121 against 83 once): the upper bound is what the log holds.
    assert 0.6 * len(sa) - 3 <= len(sb) <= counts["scan"], (len(sa), len(sb), counts["scan"])
    common = sorted(set(sa) & set(sb))
    assert len(common) >= min(len(sa), len(sb)) // 4, (len(sa), len(sb), len(common))
    # Equal where both monitors had the same transforms around the stamp. TF is published best effort, so on
    # a loaded machine the live monitor or the recorder can miss one odom sample (20 ms): the scans beside it
    # are then placed by interpolating over 40 ms. On the noise-free odometry of this robot
    # (_exact_odometry_robot) that is exact at a constant turn rate and off by at most acc_lim_th * T^2 / 8 =
    # 0.4 mrad while the rate ramps (2 mm at 5 m, the room's far wall). A scan placed with another instant's
    # transform (one sample off at 0.5 m/s: 1 cm) stays caught.
    exact = [s for s in common if np.allclose(sa[s], sb[s], atol=1e-6)]
    assert len(exact) >= 0.8 * len(common), (len(exact), len(common))
    worst = max((float(np.abs(np.asarray(sa[s]) - sb[s]).max()) for s in common), default=0.0)
    for s in common:
        assert np.allclose(sa[s], sb[s], atol=5e-3), (s, np.abs(np.asarray(sa[s]) - sb[s]).max())

    # Global plans: the monitor shows the same strips for the same plan stamps.
    pa = {r["stamp"]: r["LineStrips3D:strips"] for r in in_span(a["/world/move_base/global_plan"],
                                                                "LineStrips3D:strips")}
    pb = {r["stamp"]: r["LineStrips3D:strips"] for r in in_span(b["/world/move_base/global_plan"],
                                                                "LineStrips3D:strips")}
    shared = set(pa) & set(pb)
    assert shared, (sorted(pa), sorted(pb))
    for s in shared:
        assert np.allclose(np.array(pa[s][0]), np.array(pb[s][0]), atol=1e-9)

    print(f"recorded {end - start:.1f} s: {counts}; monitor scans A={len(sa)} B={len(sb)} common={len(common)} "
          f"(exact {len(exact)}, worst {worst * 1e3:.2f} mm), "
          f"plans A={len(pa)} B={len(pb)} common={len(shared)}")

    # Costmaps: same geometry; costs equal up to costmap_2d's OccupancyGrid table (<= 1, special values exact).
    for e in ("/world/global_costmap/costmap", "/world/local_costmap/costmap"):
        ga, gb = _grids(a, e), _grids(b, e)
        assert gb, e
        if e == "/world/global_costmap/costmap":  # published slowly: both monitors log every one
            assert set(ga) & set(gb), (e, sorted(ga), sorted(gb))
        print(f"{e}: A={len(ga)} B={len(gb)} common={len(set(ga) & set(gb))}")
        for s in set(ga) & set(gb):
            (ra, fa, da), (rb, fb, db) = ga[s], gb[s]
            assert (ra, fa) == (rb, fb), e
            assert np.abs(da.astype(int) - db.astype(int)).max() <= 1, e
            special = np.isin(da, (0, 253, 254, 255))
            assert np.array_equal(da[special], db[special]), e
