"""`zenav doctor` fails on a costmap observation source that delivers nothing, naming the costmap, the
source and its topic, with the fix (the BARN "blind robot" issue: `topic: front/scan`, nothing
publishes it). A fake robot publishes scan/odom/tf (those checks pass); a real costmap node subscribes
to front/scan."""

from __future__ import annotations

import subprocess
import sys

import pytest
import yaml
from deploy_helpers import HELPER, REPO, env_for, free_port, start, stop, wait_line, zenav

from common.messages import CostmapSensors, Header, ObservationSourceStatus
from deploy.doctor.host_checks import sensor_checks
from tests.support import wait_until


def _costmap_config(tmp_path, topic: str):
    (tmp_path / "common.yaml").write_text(yaml.safe_dump({
        "robot_radius": 0.3, "observation_sources": "scan",
        "scan": {"data_type": "LaserScan", "topic": topic, "marking": True, "clearing": True}}))
    (tmp_path / "local.yaml").write_text(yaml.safe_dump({"local_costmap": {
        "global_frame": "odom", "robot_base_frame": "base_link", "rolling_window": True, "width": 4.0,
        "height": 4.0, "resolution": 0.1, "publish_frequency": 0.0}}))
    cfg = tmp_path / "node.yaml"
    cfg.write_text(yaml.safe_dump({"name": "local_costmap", "common": "common.yaml", "specific": "local.yaml"}))
    return cfg


@pytest.fixture
def procs():
    started: list[subprocess.Popen] = []
    yield started
    for p in started:
        stop(p)


def _wait_silent(robot: str, ep: str, costmap: subprocess.Popen, timeout: float = 60.0) -> None:
    """Until the costmap reports its source silent (so the doctor's listening window sees it)."""
    from common.bus import Node
    from common.zenoh_config import BusConfig

    node = Node("doctor_test", config=BusConfig(robot=robot, multicast=False, connect=(ep,)), use_sim_time=False)
    try:
        sub = node.subscribe("local_costmap/sensors", CostmapSensors)
        wait_until(lambda: (m := sub.latest()) is not None and m.problems(), timeout, "a silent source reported",
                   period=0.05, alive=lambda: "" if costmap.poll() is None else
                   f"the costmap exited: {costmap.stderr.read()[-3000:]}")
    finally:
        node.close()


def test_doctor_fails_naming_the_silent_source_and_its_topic(procs, robot_name, tmp_path):
    robot_ep, costmap_ep = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    fake = start([sys.executable, HELPER, "fakerobot"], env_for(robot_name, ZENAV_MULTICAST="0",
                                                                ZENAV_LISTEN=robot_ep))
    procs.append(fake)
    wait_line(fake, "READY", timeout=60)
    costmap = subprocess.Popen(
        [sys.executable, "-m", "master_side.costmap.node", "--config", str(_costmap_config(tmp_path, "front/scan")),
         "--name", "local_costmap"],
        env=env_for(robot_name, ZENAV_MULTICAST="0", ZENAV_LISTEN=costmap_ep, ZENAV_CONNECT=robot_ep),
        cwd=str(REPO), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    procs.append(costmap)
    _wait_silent(robot_name, robot_ep, costmap)

    r = zenav(["doctor", "--robot", robot_name, "--no-multicast", "--connect", f"{robot_ep},{costmap_ep}",
               "--timeout", "2"], env_for())
    out = r.stdout
    assert r.returncode == 1, out + r.stderr
    fails = [line for line in out.splitlines() if line.startswith("FAIL")]
    assert len(fails) == 1, out  # scan / odom / tf / nodes pass: the silent source is the failure
    assert f"[{robot_name}] local_costmap source 'scan' on 'front/scan' silent" in fails[0]
    assert "has delivered nothing since start" in fails[0]
    assert "fix: nothing publishes 'front/scan' — check the sensor node / topic name; `zenav topic list`" in out
    assert "published topics with a similar name: scan (fake_base)" in out
    assert "1 failed (" in out.splitlines()[-1] and "local_costmap source 'scan'" in out.splitlines()[-1]
    print("\n" + out)


def _sensors(*sources: ObservationSourceStatus) -> CostmapSensors:
    return CostmapSensors(Header(1.0, "odom"), "local_costmap", sources)


def _src(state: str, messages: int = 0, rate: float = 0.0) -> ObservationSourceStatus:
    return ObservationSourceStatus("scan", "obstacle_layer", "front/scan", "LaserScan", state == "late",
                                   messages, 3.0, rate, state, f"source 'scan' ... {state}")


def test_sensor_checks_pass_skip_and_fail_with_a_fix_for_each_cause():
    [skip] = sensor_checks("r", {}, {})
    assert skip.status == "SKIP"  # no costmap: nothing to say (counts as passed)
    [ok] = sensor_checks("r", {"local_costmap": _sensors(_src("ok"))}, {})
    assert ok.status == "PASS" and "1 source(s) ok" in ok.detail
    published = {"scan": {"laser_driver"}, "odom": {"base"}}
    [silent] = sensor_checks("r", {"local_costmap": _sensors(_src("silent"))}, published)
    assert silent.status == "FAIL" and silent.name == "[r] local_costmap source 'scan' on 'front/scan' silent"
    assert silent.fix.startswith("nothing publishes 'front/scan'")
    assert "scan (laser_driver)" in silent.fix and "odom" not in silent.fix
    [announced] = sensor_checks("r", {"local_costmap": _sensors(_src("silent"))}, {"front/scan": {"drv"}})
    assert "announced by drv" in announced.fix
    [dropped] = sensor_checks("r", {"local_costmap": _sensors(_src("silent", messages=5))}, {})
    assert "cannot use them" in dropped.fix and "zenav tf tree" in dropped.fix
    [late] = sensor_checks("r", {"local_costmap": _sensors(_src("late", 9, rate=0.5))}, {})
    assert late.status == "FAIL" and "expected_update_rate 0.5 s" in late.fix
