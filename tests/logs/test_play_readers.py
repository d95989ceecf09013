"""`zenav play` readers: CARMEN logs and ROS1 bags -> LogRecords (topics, order, tf, stamps) and their errors."""

from __future__ import annotations

import collections

import numpy as np
import pytest

from common.messages import CameraInfo, DepthImage, LaserScan, Odometry, TFMessage
from common.tf_buffer import TFBuffer
from deploy.cli import main as zenav
from deploy.logs.readers import LogError, open_log
from master_side.slam.logs import read_bag, read_carmen

CARMEN = """\
# a tiny log
ODOM 0.0 0.0 0.0 0.0 0.0 0.0 10.000000 host 10.0
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.1 0.0 0.0 0.0 0.0 0.0 10.050000 host 10.05
PARAM robot_length 0.5
ODOM 0.1 0.0 0.05 0.5 0.1 0.0 10.100000 host 10.1
FLASER 5 1.5 2.5 3.5 4.5 81.9 0.2 0.0 0.1 0.15 0.01 0.08 10.150000 host 10.15
"""


def _records(path, **kw):
    it, info = open_log(path, **kw)
    return list(it), info


def test_carmen_log_plays_static_tf_then_odom_tf_before_each_scan_in_time_order(tmp_path):
    log = tmp_path / "run.clf"
    log.write_text(CARMEN)
    recs, info = _records(log)
    assert [r.topic for r in recs] == ["tf_static", "odom", "tf", "scan", "odom", "tf", "scan"]
    assert info.kind == "carmen" and (info.start, info.end) == (10.0, 10.15)
    assert info.counts["scan"] == 2 and info.counts["odom"] == 2
    stamps = [r.stamp for r in recs]
    assert stamps == sorted(stamps) and stamps[0] == 10.0
    static = recs[0].msg.transforms[0]
    assert (static.header.frame_id, static.child_frame_id) == ("base_link", "laser")
    tf, scan = recs[5].msg.transforms[0], recs[6].msg
    assert (tf.header.frame_id, tf.child_frame_id, tf.header.stamp) == ("odom", "base_link", 10.15)
    pose = tf.transform.to_pose2d()  # the FLASER line's odometry (its odom_x odom_y odom_theta)
    assert (pose.x, pose.y, pose.theta) == pytest.approx((0.15, 0.01, 0.08))
    assert isinstance(scan, LaserScan) and scan.header == type(scan.header)(10.15, "laser")
    np.testing.assert_allclose(scan.ranges, [1.5, 2.5, 3.5, 4.5, 81.9], rtol=1e-6)
    odom = recs[4].msg
    assert isinstance(odom, Odometry) and odom.pose2d.x == pytest.approx(0.1)
    assert (odom.twist.linear.x, odom.twist.angular.z) == (0.5, 0.1)


def test_laser_pose_option_sets_the_static_transform(tmp_path):
    log = tmp_path / "run.log"
    log.write_text(CARMEN)
    recs, _ = _records(log, laser_pose=(0.2, -0.1, 0.5))
    p = recs[0].msg.transforms[0].transform.to_pose2d()
    assert (p.x, p.y, p.theta) == pytest.approx((0.2, -0.1, 0.5))


def test_aces_carmen_scans_and_odometry_match_the_offline_reader(shared_dir):
    path = shared_dir / "datasets/slam/aces.recon.clf"
    offline = [r for _, r in zip(range(300), read_carmen(path))]
    it, _ = open_log(path)
    tfs, scans = {}, []
    for rec in it:
        if rec.topic == "tf":
            tfs[rec.stamp] = rec.msg.transforms[0].transform.to_pose2d()
        elif rec.topic == "scan":
            scans.append(rec)
            if len(scans) == len(offline):
                break
    for off, rec in zip(offline, scans):
        assert rec.stamp == off.stamp == rec.msg.header.stamp
        np.testing.assert_array_equal(rec.msg.ranges, off.scan.ranges)
        assert tfs[rec.stamp].as_array() == pytest.approx(off.odom.as_array(), abs=1e-12)


def test_aces_bag_tf_looked_up_at_each_scan_is_the_offline_odometry(shared_dir):
    """What the SLAM node sees online (TF interpolated at the scan stamp) is what `zenav slam run` uses."""
    path = shared_dir / "datasets/slam/ros1_bags/aces.orig.bag"
    offline = [r for _, r in zip(range(300), read_bag(path))]
    it, info = open_log(path)
    assert info.kind == "bag" and info.counts == {"tf_static": 1, "odom": 7375, "tf": 7375, "scan": 7374}
    assert info.duration == pytest.approx(1365.72, abs=0.01)
    buf, scans, topics = TFBuffer(cache_time=1e6), [], collections.Counter()
    last = -np.inf
    for rec in it:
        assert rec.stamp >= last
        last = rec.stamp
        topics[rec.topic] += 1
        if rec.topic in ("tf", "tf_static"):
            buf.set_transforms(rec.msg.transforms, static=rec.topic == "tf_static")
        elif rec.topic == "scan":
            scans.append(rec.msg)
        if len(scans) > len(offline):  # one more scan: the odometry after the last compared one is in
            break
    assert topics["tf_static"] == 1 and "" not in topics
    for off, scan in zip(offline, scans):
        assert scan.header.stamp == off.stamp
        np.testing.assert_array_equal(scan.ranges, off.scan.ranges)
        odom = buf.lookup("odom", "base_link", scan.header.stamp).transform.to_pose2d()
        # the buffer interpolates quaternions (nlerp for small angles), offline the yaw: ~1e-7 rad apart
        assert odom.as_array() == pytest.approx(off.odom.as_array(), abs=1e-6)
        assert buf.lookup("base_link", scan.header.frame_id, scan.header.stamp).transform.to_pose2d().x == 0.0


# -- a synthetic bag with every played type -----------------------------------------------------------

def _write_bag(path, with_tf: bool = True, with_static: bool = True):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    st = get_typestore(Stores.ROS1_NOETIC)
    st.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    T = st.types
    Time, Hdr = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]

    def hdr(t, frame):
        return Hdr(0, Time(int(t), int(round((t % 1) * 1e9))), frame)

    def tfm(t, parent, child, x):
        return T["tf2_msgs/msg/TFMessage"]([T["geometry_msgs/msg/TransformStamped"](
            hdr(t, parent), child, T["geometry_msgs/msg/Transform"](V3(x, 0.0, 0.0), Q(0.0, 0.0, 0.0, 1.0)))])

    def odom(t, x):
        P, Tw = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/Twist"]
        return T["nav_msgs/msg/Odometry"](hdr(t, "/odom"), "base_link", T["geometry_msgs/msg/PoseWithCovariance"](
            P(T["geometry_msgs/msg/Point"](x, 0.0, 0.0), Q(0.0, 0.0, 0.0, 1.0)), np.zeros(36)),
            T["geometry_msgs/msg/TwistWithCovariance"](Tw(V3(0.5, 0, 0), V3(0, 0, 0.1)), np.zeros(36)))

    def scan(t):
        return T["sensor_msgs/msg/LaserScan"](hdr(t, "/base_laser"), -1.0, 1.0, 0.5, 0.0, 0.1, 0.1, 30.0,
                                              np.array([1, 2, 3, 4, 5], np.float32), np.zeros(0, np.float32))

    def image(t, enc, data, step):
        return T["sensor_msgs/msg/Image"](hdr(t, "camera_depth_optical_frame"), 2, 2, enc, 0, step,
                                          np.frombuffer(data, np.uint8))

    info = T["sensor_msgs/msg/CameraInfo"](hdr(1.0, "camera_depth_optical_frame"), 2, 2, "plumb_bob", np.zeros(5),
                                           np.array([500.0, 0, 1.0, 0, 501.0, 0.5, 0, 0, 1]), np.eye(3).ravel(),
                                           np.zeros(12), 0, 0, T["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False))
    msgs = [("/odom", 1.0, odom(1.0, 0.0)), ("/scan", 1.05, scan(1.05)), ("/odom", 1.1, odom(1.1, 0.1)),
            ("/camera/depth/camera_info", 1.2, info),
            ("/camera/depth/image_raw", 1.2, image(1.2, "16UC1", np.array([1000, 0, 2500, 65535], "<u2").tobytes(), 4)),
            ("/camera/depth/image", 1.25, image(1.25, "32FC1", np.array([1.5, np.nan, 2, 3], "<f4").tobytes(), 8)),
            ("/camera/rgb/image_color", 1.25, image(1.25, "rgb8", bytes(12), 6)),
            ("/chatter", 1.3, T["std_msgs/msg/String"]("hello"))]
    if with_tf:
        msgs += [("/tf", 1.0, tfm(1.0, "odom", "base_link", 0.0)), ("/tf", 1.1, tfm(1.1, "odom", "base_link", 0.1))]
    if with_static:
        msgs += [("/tf_static", 1.0, tfm(1.0, "base_link", "base_laser", 0.3))]
    with Writer(path) as w:
        conns = {}
        for topic, t, m in sorted(msgs, key=lambda x: x[1]):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, m.__msgtype__, typestore=st)
            w.write(conns[topic], int(t * 1e9), st.serialize_ros1(m, m.__msgtype__))


def test_bag_plays_scan_odom_tf_depth_and_camera_info_under_topic_names_without_slash(tmp_path):
    _write_bag(tmp_path / "a.bag")
    recs, info = _records(tmp_path / "a.bag")
    topics = [r.topic for r in recs]
    assert collections.Counter(topics) == {"odom": 2, "tf": 2, "tf_static": 1, "scan": 1, "camera/depth/image_raw": 1,
                                           "camera/depth/image": 1, "camera/depth/camera_info": 1}
    assert "chatter" in " ".join(info.skipped) and [r.stamp for r in recs] == sorted(r.stamp for r in recs)
    by = {r.topic: r.msg for r in recs}
    assert by["scan"].header.frame_id == "base_laser" and by["odom"].header.frame_id == "odom"
    assert by["tf_static"].transforms[0].transform.translation.x == 0.3  # the bag's own, kept
    mm = by["camera/depth/image_raw"]
    assert isinstance(mm, DepthImage) and mm.depth.dtype == np.float32
    np.testing.assert_allclose(mm.depth, [[1.0, 0.0], [2.5, 65.535]])
    np.testing.assert_array_equal(by["camera/depth/image"].depth, np.array([[1.5, np.nan], [2, 3]], np.float32))
    ci = by["camera/depth/camera_info"]
    assert isinstance(ci, CameraInfo) and (ci.width, ci.fx, ci.fy, ci.cx, ci.cy) == (2, 500.0, 501.0, 1.0, 0.5)


def test_bag_without_tf_gets_odom_tf_and_a_default_static_laser_transform(tmp_path):
    _write_bag(tmp_path / "b.bag", with_tf=False, with_static=False)
    recs, _ = _records(tmp_path / "b.bag")
    assert recs[0].topic == "tf_static"
    st = recs[0].msg.transforms[0]
    assert (st.header.frame_id, st.child_frame_id, st.transform.translation.x) == ("base_link", "base_laser", 0.0)
    tfs = [r.msg for r in recs if r.topic == "tf"]
    assert [m.transforms[0].transform.translation.x for m in tfs] == [0.0, 0.1]
    assert isinstance(tfs[0], TFMessage) and tfs[0].transforms[0].header.frame_id == "odom"
    assert [r.topic for r in recs].index("tf") == [r.topic for r in recs].index("odom") + 1


def test_laser_pose_replaces_the_bags_own_static_laser_transform(tmp_path):
    _write_bag(tmp_path / "c.bag")
    recs, _ = _records(tmp_path / "c.bag", laser_pose=(0.1, 0.0, 0.0))
    statics = [ts for r in recs if r.topic == "tf_static" for ts in r.msg.transforms]
    assert [ts.transform.translation.x for ts in statics] == [pytest.approx(0.1)]


# -- errors -----------------------------------------------------------------------------------------

def test_missing_damaged_and_unknown_files_are_one_line_log_errors(tmp_path):
    with pytest.raises(LogError, match="no such file"):
        open_log(tmp_path / "nope.bag")
    bad = tmp_path / "bad.bag"
    bad.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(LogError, match="not a readable ROS1 bag") as e:
        open_log(bad)
    assert "\n" not in str(e.value)
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(LogError, match="unknown log type"):
        open_log(tmp_path / "x.txt")
    (tmp_path / "empty.clf").write_text("# nothing\nPARAM a 1\n")
    with pytest.raises(LogError, match="no FLASER"):
        open_log(tmp_path / "empty.clf")
    (tmp_path / "bin.clf").write_bytes(b"\xff\xfe\x00FLASER")
    with pytest.raises(LogError, match="not a CARMEN text log"):
        open_log(tmp_path / "bin.clf")


def test_malformed_carmen_line_names_the_line_while_playing(tmp_path):
    log = tmp_path / "m.clf"
    log.write_text(CARMEN + "FLASER 5 1.0 2.0 oops\n")
    it, _ = open_log(log)
    with pytest.raises(LogError, match=r"m\.clf:7: malformed FLASER line"):
        list(it)


def test_zenav_play_on_a_missing_or_damaged_file_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.bag"
    bad.write_bytes(b"not a bag at all")
    for path in (tmp_path / "missing.clf", bad):
        assert zenav(["play", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("zenav play: ") and err.count("\n") == 1, err
    assert zenav(["play", str(bad), "--remap", "scan"]) == 2
    assert "OLD:=NEW" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        zenav(["play", str(bad), "--start", "-1"])
    assert e.value.code == 2
