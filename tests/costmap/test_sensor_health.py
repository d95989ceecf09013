"""Sensor health of the costmaps (master_side.costmap.health): the costmap node's per-source watch, the
reader other nodes use, and the CostmapSensors message through the codec."""

from __future__ import annotations

import numpy as np
import pytest
from costmap_helpers import source

from common.codec import decode, encode
from common.messages import CostmapSensors, Header, ObservationSourceStatus, msg_equal
from master_side.costmap.health import LATE, OK, SILENT, SensorHealth, SensorWatch, summary
from master_side.costmap.observation import ObservationBuffer

PTS, ORIGIN = np.array([[1.0, 0.0, 0.2]]), np.zeros(3)


def watch_of(**src) -> tuple[SensorWatch, ObservationBuffer]:
    """A watch started at monotonic 100.0 with one source 'scan' on topic 'front/scan'."""
    buf = ObservationBuffer("scan", source(topic="front/scan", **src))
    w = SensorWatch("local_costmap", started=100.0, grace=1.0)
    w.add("obstacle_layer", buf, "LaserScan")
    return w, buf


def report(w: SensorWatch, now: float, mono: float):
    msg, events = w.report(Header(now, "odom"), now, mono)
    (st,) = msg.sources
    return st, events


def test_a_source_that_never_delivers_turns_silent_after_the_grace_whatever_its_rate():
    w, _ = watch_of(expected_update_rate=0.0)  # ROS would never complain
    st, events = report(w, 50.0, 100.5)
    assert (st.state, st.delivered, events) == (OK, False, [])
    assert "waiting for the first reading" in st.detail
    st, events = report(w, 50.0, 101.2)
    assert st.state == SILENT
    assert (st.source, st.topic, st.data_type, st.layer) == ("scan", "front/scan", "LaserScan", "obstacle_layer")
    assert st.age_s == pytest.approx(1.2)
    assert st.detail == "source 'scan' on topic 'front/scan' (LaserScan) has delivered nothing since start 1.2 s ago"
    [(level, text)] = events
    assert level == "WARNING"
    assert "local_costmap" in text and "nothing publishes 'front/scan'" in text and "zenav topic list" in text
    # once per change of state, not every cycle
    assert report(w, 51.0, 103.0)[1] == []


def test_a_source_with_a_rate_is_silent_once_the_rate_has_passed_without_a_reading():
    w, _ = watch_of(expected_update_rate=0.3)
    assert report(w, 0.0, 100.2)[0].state == OK
    assert report(w, 0.0, 100.4)[0].state == SILENT


def test_a_reading_recovers_the_source_and_a_gap_longer_than_the_rate_makes_it_late():
    w, buf = watch_of(expected_update_rate=0.5)
    report(w, 10.0, 102.0)  # silent
    w.received("obstacle_layer", "scan")
    buf.add(PTS, ORIGIN, stamp=3.0, received=10.1)  # stamp on another clock: ROS times the buffering
    w.used("obstacle_layer", "scan")
    st, events = report(w, 10.2, 102.2)
    assert (st.state, st.delivered, st.messages) == (OK, True, 1)
    assert st.age_s == pytest.approx(0.1)
    [(level, text)] = events
    assert level == "INFO" and "recovered (silent before)" in text
    st, events = report(w, 10.7, 102.7)
    assert st.state == LATE
    assert "last reading 0.6 s ago, expected_update_rate 0.5 s" in st.detail
    assert [e[0] for e in events] == ["WARNING"]
    assert report(w, 10.9, 102.9)[1] == []


def test_messages_the_costmap_cannot_use_do_not_count_as_delivered_and_say_why():
    w, _ = watch_of()
    for _ in range(3):
        w.received("obstacle_layer", "scan")
        w.dropped("obstacle_layer", "scan", "no transform odom <- laser: unknown frame")
    st, events = report(w, 0.0, 102.0)
    assert (st.state, st.messages, st.delivered) == (SILENT, 3, False)
    assert "3 message(s) arrived, none usable (last: no transform odom <- laser" in st.detail
    assert "nothing publishes" not in events[0][1]  # something does: the hint would mislead
    w2, _ = watch_of()
    w2.received("obstacle_layer", "scan")  # still being processed (waiting for its transform) at the report
    st, _ = report(w2, 0.0, 102.0)
    assert st.detail.endswith("1 message(s) arrived, none processed yet")  # not "none usable (last: )"


def test_payloads_of_another_type_are_named_in_the_silent_detail():
    w, _ = watch_of()
    w.malformed("obstacle_layer", "scan", 4)
    st, _ = report(w, 0.0, 102.0)
    assert "4 payload(s) on the topic are not LaserScan" in st.detail


def test_ros_is_current_times_the_buffering_and_ignores_a_zero_rate():
    buf = ObservationBuffer("scan", source(expected_update_rate=0.5))
    assert not buf.is_current(0.0)  # nothing yet
    buf.add(PTS, ORIGIN, stamp=1000.0, received=5.0)
    assert buf.is_current(5.5)
    assert not buf.is_current(5.6)
    assert ObservationBuffer("scan", source(expected_update_rate=0.0)).is_current(1e9)


def _status(costmap: str, stamp: float, *states: str) -> CostmapSensors:
    srcs = tuple(ObservationSourceStatus(f"s{i}", "obstacle_layer", f"t{i}", "LaserScan", st != SILENT, 1, 0.1,
                                         0.0, st, f"source 's{i}' detail {st}") for i, st in enumerate(states))
    return CostmapSensors(Header(stamp, "map"), costmap, srcs)


def test_sensor_health_is_one_line_and_a_boolean_for_move_base():
    h = SensorHealth()
    assert h.problem(10.0) == "" and h.ok(10.0)  # nothing heard of and nothing required
    h.update(_status("local_costmap", 10.0, OK, OK))
    h.update(_status("global_costmap", 10.0, OK))
    assert h.problem(10.5) == ""
    h.update(_status("local_costmap", 11.0, OK, SILENT))
    assert h.problem(11.5) == "local_costmap: source 's1' detail silent"
    assert not h.ok(11.5)
    # a costmap whose status stopped arriving is not reporting
    assert h.problem(14.0, max_age=2.5).startswith("costmap global_costmap not reporting (last global_costmap")
    assert h.latest("local_costmap").sources[1].state == SILENT


def test_sensor_health_names_a_required_costmap_that_never_reported():
    h = SensorHealth(required=("local_costmap",))
    assert h.problem(1.0) == "costmap local_costmap not reporting (nothing on local_costmap/sensors yet)"
    h.update(_status("local_costmap", 5.0, OK), received=1.0)  # the reader's own clock
    assert h.problem(1.5) == ""


def test_summary_names_the_problems_or_counts_the_good_sources():
    assert summary(_status("g", 0.0, OK, LATE)) == "g: source 's1' detail late"
    assert summary(_status("g", 0.0, OK)) == "g: 1 source(s) ok ('s0' on 't0')"
    assert summary(_status("g", 0.0)) == "g: no observation sources"


def test_costmap_sensors_round_trips_through_the_codec():
    msg = _status("local_costmap", 12.5, OK, LATE, SILENT)
    back = decode(encode(msg), CostmapSensors)
    assert msg_equal(back, msg)
    assert [s.state for s in back.problems()] == [LATE, SILENT]
