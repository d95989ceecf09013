"""`zenav slam run` on an MCAP file as `zenav record` writes it: scans, odometry and tf_static (the laser's
place on the base), written with the recorder's own writer and mapped offline through the `zenav` command."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.messages import Header, Odometry, TFMessage, TransformStamped
from deploy.cli import main as zenav
from deploy.logs.mcap_io import McapLogWriter, read_records
from master_side.slam.logs import LogError, scan_records
from tests.slam.conftest import _room_scan

LASER_X = 0.2  # the laser 0.2 m ahead of base_link: a turn in place moves it on a circle


def _pose_at(t: float) -> Pose2D:
    """Turn in place at 0.4 rad/s for 4 s, then drive 0.3 m/s on the new heading for 6 s."""
    x0, y0, th0 = -2.0, -1.5, 0.0
    if t <= 4.0:
        return Pose2D(x0, y0, th0 + 0.4 * t)
    th = th0 + 1.6
    return Pose2D(x0 + 0.3 * (t - 4.0) * math.cos(th), y0 + 0.3 * (t - 4.0) * math.sin(th), th)


def _transform(p: Pose2D) -> Transform:
    return Transform(Vector3(p.x, p.y, 0.0), Quaternion.from_yaw(p.theta))


def _write(path, tf_static: bool = True, odom: bool = True, tf_at: float = 0.0) -> list[Pose2D]:
    """Odometry (exact, 50 Hz) and laser scans (10 Hz) of the drive in the synthetic room, in log order;
    the laser's static transform at ``tf_at`` s."""
    w = McapLogWriter(str(path))
    laser = Pose2D(LASER_X, 0.0, 0.0)
    truth = []
    for k in range(501):
        t = 0.02 * k
        if tf_static and k == round(tf_at / 0.02):
            w.write("tf_static", TFMessage((TransformStamped(Header(t, "base_link"), "laser", _transform(laser)),)), t)
        base = _pose_at(t)
        if odom:
            w.write("odom", Odometry(Header(t, "odom"), "base_link", _transform(base)), t)
        if k % 5 == 0:
            scan = _room_scan(base.compose(laser))
            w.write("scan", type(scan)(**{**scan.__dict__, "header": Header(t, "laser")}), t)
            truth.append(base)
    w.close()
    return truth


@pytest.mark.parametrize("tf_at", [0.0, 1.01])
def test_scan_records_carry_the_odometry_at_each_scan_and_the_lasers_place(tmp_path, tf_at):
    """Also when the laser's static transform comes after the first scans (a recording started before the
    robot: its first scans wait for it, none is lost)."""
    path = tmp_path / "run.mcap"
    truth = _write(path, tf_at=tf_at)
    recs = list(scan_records(((r.topic, r.msg) for r in read_records(path)), str(path)))
    assert len(recs) == len(truth)
    for rec, base in zip(recs, truth):
        assert rec.odom.between(base).as_array() == pytest.approx(np.zeros(3), abs=1e-6)
        assert rec.laser.as_array() == pytest.approx([LASER_X, 0.0, 0.0], abs=1e-9)


def test_zenav_slam_run_maps_an_mcap_recording_with_the_laser_where_tf_static_puts_it(tmp_path, capsys):
    """The trajectory is the base's: had the 0.2 m mount been ignored, the turn in place would put the
    estimated base on the laser's circle, 0.2 m off."""
    path = tmp_path / "run.mcap"
    truth = _write(path)
    out = tmp_path / "out"
    rc = zenav(["slam", "run", str(path), "--out", str(out), "--particles", "2", "--set", "linearUpdate=0.1",
                "--set", "angularUpdate=0.1", "--set", "maxUrange=20.0", "--set", "maxRange=25.0"])
    assert rc == 0, capsys.readouterr().err
    traj = np.loadtxt(out / "trajectory.txt")
    assert len(traj) == len(truth)
    want = np.array([b.as_array() for b in truth])  # the filter starts at the first odometry pose
    err = np.hypot(*(traj[:, 1:3] - want[:, :2]).T)
    assert err.max() < 0.05, f"worst {err.max():.3f} m at scan {err.argmax()}"
    assert (out / "map.yaml").exists()


def test_a_recording_without_tf_static_or_odometry_is_refused_with_the_reason(tmp_path, capsys):
    no_tf = tmp_path / "no_tf.mcap"
    _write(no_tf, tf_static=False)
    assert zenav(["slam", "run", str(no_tf), "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "'laser'" in err and "base_link" in err and "tf_static" in err
    no_odom = tmp_path / "no_odom.mcap"
    _write(no_odom, odom=False)
    assert zenav(["slam", "run", str(no_odom), "--out", str(tmp_path / "b")]) == 2
    assert "no odom messages" in capsys.readouterr().err
    with pytest.raises(LogError, match="no odom"):
        list(scan_records([], "empty"))
