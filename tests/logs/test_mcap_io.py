"""MCAP writing and reading: every message type round-trips (ROS1 encoding where a standard type exists,
our msgpack otherwise), the schemas are the standard ROS1 definitions (checked against rosbags' ROS1
type store, md5 included), files written by other ROS1 tools read back, a broken file is one clear error."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from common import messages as m
from deploy.logs import ros1_decode, ros1_msgs
from deploy.logs.mcap_io import LogClock, McapLogWriter, McapReadError, read_info, read_records
from tests.logs.mcap_samples import WALL, assert_ros1_equal, msgpack_samples, ros1_samples

rosbags_typesys = pytest.importorskip("rosbags.typesys")
@pytest.fixture
def written(tmp_path):
    """A file with every sample twice (log times 100 s apart), in reverse log-time order on disk."""
    path = tmp_path / "all.mcap"
    w = McapLogWriter(str(path))
    samples = {**ros1_samples(), **msgpack_samples()}
    times = {t: 1000.0 + 0.01 * i for i, t in enumerate(samples)}
    for topic, msg in reversed(list(samples.items())):
        for k in (1, 0):
            w.write(topic, msg, log_time=times[topic] + 100 * k, publish_time=5.0)
    w.close()
    return path, samples, times


def test_every_message_type_round_trips_field_by_field(written):
    path, samples, times = written
    records = list(read_records(path))
    assert len(records) == 2 * len(samples)
    stamps = [r.stamp for r in records]
    assert stamps == sorted(stamps)
    assert {r.topic for r in records} == set(samples)
    ros1, packed = ros1_samples(), msgpack_samples()
    for r in records:
        if r.topic in ros1:
            assert_ros1_equal(r.msg, ros1[r.topic], r.topic)
        else:
            assert m.msg_equal(r.msg, packed[r.topic]), r.topic
    assert [r.stamp for r in records] == pytest.approx(sorted([*times.values(), *(t + 100 for t in times.values())]))
    assert [r.topic for r in records[: len(samples)]] == list(samples)
    start, end, counts = read_info(path)
    assert (start, end) == (pytest.approx(stamps[0]), pytest.approx(stamps[-1]))
    assert counts == {t: 2 for t in samples}


def test_plain_mcap_reader_sees_ros1_schemas_and_our_metadata(written):
    path, samples, _ = written
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    by_topic = {c.topic: c for c in summary.channels.values()}
    assert set(by_topic) == {"/" + t for t in samples}
    store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS1_NOETIC)
    for topic, msg in samples.items():
        ch = by_topic["/" + topic]
        schema = summary.schemas[ch.schema_id]
        name = type(msg)._msg_name
        assert ch.metadata["zenav_type"] == name
        if topic in ros1_samples():
            assert (schema.encoding, ch.message_encoding, schema.name) == ("ros1msg", "ros1", ros1_msgs.ROS_TYPES[name])
            text = schema.data.decode()
            assert text == ros1_msgs.full_definition(schema.name)
            # Structure identical to the standard ROS1 type: same md5sum as rosbags' ROS1 (noetic) store.
            rosname = schema.name.replace("/", "/msg/")
            fresh = rosbags_typesys.get_typestore(rosbags_typesys.Stores.EMPTY)
            fresh.register(rosbags_typesys.get_types_from_msg(text, rosname))
            md5 = fresh.generate_msgdef(rosname, ros_version=1)[1]
            assert md5 == ch.metadata["md5sum"]
            if rosname in store.types:
                assert md5 == store.generate_msgdef(rosname, ros_version=1)[1]
        else:
            assert (schema.encoding, ch.message_encoding, schema.name) == ("zenav-msgpack", "zenav-msgpack", name)
    assert by_topic["/local_costmap/costmap/obstacle_layer"].metadata["costmap_layer"] == "obstacle_layer"
    text = summary.schemas[by_topic["/odom"].schema_id].data.decode()
    assert text.count("=" * 80 + "\nMSG: ") == 8 and "\nMSG: geometry_msgs/PoseWithCovariance\n" in text


def test_our_ros1_bytes_are_what_rosbags_reads():
    """Cross-check of the serializers against an independent ROS1 implementation (rosbags)."""
    store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS1_NOETIC)
    store.register(rosbags_typesys.get_types_from_msg(ros1_msgs.full_definition("tf2_msgs/TFMessage"),
                                                      "tf2_msgs/msg/TFMessage"))
    s = ros1_samples()
    scan = store.deserialize_ros1(ros1_msgs.serialize(s["scan"])[1], "sensor_msgs/msg/LaserScan")
    assert np.array_equal(scan.ranges, s["scan"].ranges, equal_nan=True) and scan.header.frame_id == "laser"
    assert (scan.header.stamp.sec, scan.header.stamp.nanosec) == ros1_msgs.time_parts(WALL)
    grid = store.deserialize_ros1(ros1_msgs.serialize(s["map"])[1], "nav_msgs/msg/OccupancyGrid")
    assert (grid.info.width, grid.info.height) == (5, 7) and np.array_equal(grid.data, s["map"].data.ravel())
    plan = store.deserialize_ros1(ros1_msgs.serialize(s["move_base/global_plan"])[1], "nav_msgs/msg/Path")
    assert [p.pose.position.x for p in plan.poses] == list(s["move_base/global_plan"].poses[:, 0])
    img = store.deserialize_ros1(ros1_msgs.serialize(s["camera/depth/image"])[1], "sensor_msgs/msg/Image")
    assert (img.encoding, img.height, img.width, img.step) == ("32FC1", 6, 8, 32)
    info = store.deserialize_ros1(ros1_msgs.serialize(s["camera/depth/camera_info"])[1], "sensor_msgs/msg/CameraInfo")
    assert list(info.K) == [525.0, 0, 319.5, 0, 526.5, 239.5, 0, 0, 1] and info.P[5] == 526.5
    tf = store.deserialize_ros1(ros1_msgs.serialize(s["tf"])[1], "tf2_msgs/msg/TFMessage")
    assert [t.child_frame_id for t in tf.transforms] == ["odom", "base_link"]
    assert tf.transforms[1].transform.translation.x == 3.0


def _foreign_file(path, store, items):
    """An MCAP file as another ROS1 tool writes it: rosbags' definitions and bytes, no zenav metadata."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros1", library="other")
        for i, (topic, rostype, msg) in enumerate(items):
            text, md5 = store.generate_msgdef(rostype, ros_version=1)
            sid = w.register_schema(name=rostype.replace("/msg/", "/"), encoding="ros1msg", data=text.encode())
            cid = w.register_channel(topic=topic, message_encoding="ros1", schema_id=sid, metadata={"md5sum": md5})
            w.add_message(channel_id=cid, log_time=(10 + i) * 10**9, publish_time=0,
                          data=bytes(store.serialize_ros1(msg, rostype)))
        w.finish()


def test_files_of_other_ros1_tools_read_back(tmp_path):
    store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS1_NOETIC)
    T = store.types  # noqa: N806
    hdr = T["std_msgs/msg/Header"](seq=4, stamp=T["builtin_interfaces/msg/Time"](sec=7, nanosec=250_000_000),
                                   frame_id="cam")
    mm = np.array([[0, 1500], [2000, 65535]], "<u2")
    pose = T["geometry_msgs/msg/Pose"](T["geometry_msgs/msg/Point"](1.0, 2.0, 0.0),
                                       T["geometry_msgs/msg/Quaternion"](0.0, 0.0, math.sin(0.4), math.cos(0.4)))
    meta = T["nav_msgs/msg/MapMetaData"](hdr.stamp, 0.1, 3, 2, pose)
    items = [
        ("/camera/depth/image_raw", "sensor_msgs/msg/Image",
         T["sensor_msgs/msg/Image"](hdr, 2, 2, "16UC1", 0, 4, mm.view(np.uint8).ravel())),
        ("/camera/rgb/image", "sensor_msgs/msg/Image",
         T["sensor_msgs/msg/Image"](hdr, 1, 1, "rgb8", 0, 3, np.zeros(3, np.uint8))),
        ("/move_base/global_costmap/costmap", "nav_msgs/msg/OccupancyGrid",
         T["nav_msgs/msg/OccupancyGrid"](hdr, meta, np.array([0, 50, 99, 100, -1, 1], np.int8))),
        ("/move_base/local_costmap/costmap/obstacle_layer", "nav_msgs/msg/OccupancyGrid",
         T["nav_msgs/msg/OccupancyGrid"](hdr, meta, np.array([0, 50, 99, 100, -1, 1], np.int8))),
        ("/map", "nav_msgs/msg/OccupancyGrid",
         T["nav_msgs/msg/OccupancyGrid"](hdr, meta, np.array([0, 50, 99, 100, -1, 1], np.int8))),
        ("/rosout_agg_count", "std_msgs/msg/UInt32", T["std_msgs/msg/UInt32"](3)),
    ]
    _foreign_file(tmp_path / "other.mcap", store, items)
    recs = {r.topic: r for r in read_records(tmp_path / "other.mcap")}
    assert set(recs) == {"camera/depth/image_raw", "move_base/global_costmap/costmap", "map",
                         "move_base/local_costmap/costmap/obstacle_layer"}  # rgb8 image, UInt32 skipped
    depth = recs["camera/depth/image_raw"].msg
    assert depth.header == m.Header(7.25, "cam") and depth.depth.dtype == np.float32
    assert np.array_equal(depth.depth, np.array([[0, 1.5], [2.0, 65.535]], np.float32))
    cm = recs["move_base/global_costmap/costmap"].msg
    assert isinstance(cm, m.Costmap) and cm.data.shape == (2, 3)
    assert list(cm.data.ravel()[[0, 2, 3, 4]]) == [0, 253, 254, 255]
    assert (cm.layer, recs["move_base/local_costmap/costmap/obstacle_layer"].msg.layer) == ("", "obstacle_layer")
    grid = recs["map"].msg
    assert isinstance(grid, m.OccupancyGrid) and grid.resolution == 0.1 and grid.origin.theta == pytest.approx(0.8)
    assert recs["map"].stamp == 14.0


def test_corrupt_data_inside_a_complete_file_is_one_clear_error(written, tmp_path):
    path, _, _ = written
    data = bytearray(path.read_bytes())
    mid = len(data) // 3
    data[mid : mid + 64] = bytes(64)  # inside a compressed chunk
    bad = tmp_path / "flipped.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(McapReadError) as e:
        list(read_records(bad))
    assert str(bad) in str(e.value) and "corrupt" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty", "missing"])
def test_a_broken_file_is_one_clear_error(written, tmp_path, damage):
    path, _, _ = written
    bad = tmp_path / "bad.mcap"
    data = path.read_bytes()
    if damage == "truncated":
        bad.write_bytes(data[: len(data) * 2 // 3])
    elif damage == "garbage":
        bad.write_bytes(b"not an mcap file at all" * 10)
    elif damage == "empty":
        bad.write_bytes(b"")
    with pytest.raises(McapReadError) as e:
        read_records(bad)  # raised at once, before iterating
    text = str(e.value)
    assert str(bad) in text and "\n" not in text
    assert {"truncated": "truncated", "garbage": "not an MCAP", "empty": "empty", "missing": "cannot read"}[
        damage] in text


def test_corrupt_ros1_bytes_raise_decode_errors():
    scan = ros1_msgs.serialize(ros1_samples()["scan"])[1]
    for bad in (scan[:-3], scan + b"\0", b"\xff" * 20):
        with pytest.raises(ros1_decode.Ros1DecodeError):
            ros1_decode.deserialize("sensor_msgs/LaserScan", bad)


def test_log_clock_uses_stamps_near_the_bus_clock():
    c = LogClock(tolerance=60.0)
    assert c.log_time(0.0, WALL) == WALL  # no stamp, no clock: receive time
    assert c.log_time(WALL - 1.0, WALL) == WALL - 1.0
    c = LogClock()
    assert c.log_time(5.0, WALL) == 5.0  # simulated stamps are the time base
    assert c.log_time(0.0, WALL) == 5.0
    assert c.log_time(WALL, WALL) == 5.0  # an agent's wall stamp during a simulation
    c.update_clock(300.0)
    assert c.log_time(1.0, WALL) == 300.0  # latched long ago
    assert c.log_time(299.5, WALL) == 299.5
