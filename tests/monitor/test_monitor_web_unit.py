"""The web page's pieces without a browser: WebState (what the map panel shows), the HTTP server's
control endpoints (token, content type, validation, what goes on the bus) and the particle cloud display."""

from __future__ import annotations

import json
import math
import urllib.error
import urllib.request

import numpy as np
import pytest
import rerun as rr
from monhelp import read_rrd, values

from common import messages as m
from common.geometry import Pose2D
from deploy.monitor import loggers as L
from deploy.monitor.webserver import WebServer
from deploy.monitor.webstate import WebState, covariance_ellipse


def _tf(parent: str, child: str, p: Pose2D) -> m.TFMessage:
    return m.TFMessage([m.TransformStamped(m.Header(1.0, parent), child, p.to_transform())])


def _state() -> WebState:
    st = WebState("r1")
    st.observe("tf", _tf("map", "odom", Pose2D(1.0, 0.0, math.pi / 2)))
    st.observe("tf", _tf("odom", "base_link", Pose2D(1.0, 0.0, 0.0)))
    st.observe("map", m.OccupancyGrid(m.Header(0.0, "map"), 0.5, Pose2D(-1.0, -2.0, 0.0),
                                      np.array([[0, 100], [-1, 50]], np.int8)))
    return st


def test_the_state_puts_the_robot_in_the_map_through_tf_and_serves_the_map():
    assert WebState("r1").snapshot()["data_age_s"] is None  # the page says: no data from the robot yet
    st = _state()
    snap = st.snapshot()
    assert 0.0 <= snap["data_age_s"] < 5.0  # live
    assert snap["pose"] == pytest.approx({"x": 1.0, "y": 1.0, "yaw": round(math.pi / 2, 4)}, abs=1e-3)
    mp = st.map_payload()
    assert (mp["width"], mp["height"], mp["resolution"]) == (2, 2, 0.5)
    assert mp["origin"] == {"x": -1.0, "y": -2.0, "yaw": 0.0}
    import base64

    # image order (top row = the grid's last row): unknown, 50 %, then free, occupied
    assert list(base64.b64decode(mp["data"])) == [128, 127, 254, 0]


def test_particles_give_the_covariance_ellipse_and_the_why_line_skips_the_idle_stale_command():
    rng = np.random.default_rng(1)
    xy = rng.standard_normal((4000, 2)) * [0.4, 0.1] + [2.0, -1.0]
    c, axes, angle = covariance_ellipse(xy)
    assert c == pytest.approx([2.0, -1.0], abs=0.03)
    assert axes == pytest.approx([0.8, 0.2], rel=0.08)  # 2 sigma
    assert abs(math.sin(angle)) < 0.05
    st = _state()
    st.observe("particlecloud", m.Path(m.Header(1.0, "map"), np.column_stack((xy, np.zeros(len(xy))))))
    snap = st.snapshot()
    assert len(snap["particles"]) <= 700 and snap["ellipse"]["a"] == pytest.approx(0.8, rel=0.08)
    st.observe("collision_monitor/state", m.CollisionMonitorState(action="stale_cmd", reason="no cmd_vel"))
    st.observe("move_base/status", m.MoveBaseStatus(state="IDLE", reason="no goal"))
    assert st.why_not_moving() == "no goal"
    st.observe("move_base/status", m.MoveBaseStatus(state="CONTROLLING", reason="blocked"))
    assert st.why_not_moving() == "blocked; robot safety: stale_cmd (no cmd_vel)"


@pytest.fixture
def server():
    sent = []
    def send(what, msg):
        sent.append((what, msg))
        return f"{what} taken"

    srv = WebServer(_state(), send, 0, 9876, token="tok")
    yield srv, sent
    srv.close()


def _req(srv, path, body=None, token=None, ctype="application/json"):
    headers = {"Content-Type": ctype}
    if token:
        headers["X-Zenav-Token"] = token
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(f"http://127.0.0.1:{srv.port}{path}", data, headers)
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def test_the_control_endpoints_publish_only_with_the_token_and_valid_numbers(server):
    srv, sent = server
    assert srv.httpd.server_address[0] == "127.0.0.1"
    assert _req(srv, "/api/goal", {"x": 1, "y": 2, "yaw": 0})[0] == 403
    assert _req(srv, "/api/goal", {"x": 1, "y": 2, "yaw": 0}, "bad")[0] == 403
    assert _req(srv, "/api/goal", {"x": 1, "y": 2, "yaw": 0}, "tok", "text/plain")[0] == 415
    assert _req(srv, "/api/goal", {"x": "nan", "y": 2, "yaw": 0}, "tok")[0] == 400
    assert _req(srv, "/api/goal", {"x": 1}, "tok")[0] == 400
    assert sent == []
    assert _req(srv, "/api/goal", {"x": 1.5, "y": -0.5, "yaw": 1.0}, "tok")[0] == 200
    assert _req(srv, "/api/initialpose", {"x": -2.2, "y": 0, "yaw": 0}, "tok")[0] == 200
    assert _req(srv, "/api/cancel", {}, "tok")[0] == 200
    assert [t for t, _ in sent] == ["goal", "initialpose", "cancel"]
    goal = sent[0][1]
    assert goal.header.frame_id == "map"
    p = goal.pose.to_pose2d()
    assert (p.x, p.y, p.theta) == pytest.approx((1.5, -0.5, 1.0))
    assert sent[2][1] is None
    code, body = _req(srv, "/api/state")
    assert code == 200 and json.loads(body)["events"][-1] == "cancel: cancel taken"


def test_a_waypoint_queue_goes_as_one_mission_and_a_bad_one_is_refused_naming_the_waypoint(server):
    srv, sent = server
    code, body = _req(srv, "/api/mission", {"waypoints": [{"x": 1, "y": 2, "yaw": 0}, {"x": 1}]}, "tok")
    assert code == 400 and "waypoint 2: expected numbers x, y, yaw" in json.loads(body)["error"]
    assert _req(srv, "/api/mission", {"waypoints": []}, "tok")[0] == 400
    assert _req(srv, "/api/mission", {"waypoints": [{"x": 1, "y": 2, "yaw": 0}], "loop": "yes"}, "tok")[0] == 400
    assert _req(srv, "/api/mission", {"waypoints": [{"x": 0, "y": 0, "yaw": 0}] * 101}, "tok")[0] == 400
    assert sent == []
    wps = [{"x": 1.0, "y": 2.0, "yaw": 0.5}, {"x": -2.2, "y": 0.0, "yaw": 3.0}]
    code, body = _req(srv, "/api/mission", {"waypoints": wps, "loop": True}, "tok")
    assert code == 200 and json.loads(body)["waypoints"] == 2
    ((what, (poses, loop)),) = sent
    assert what == "mission" and loop is True
    assert [tuple(round(v, 6) for v in (q.pose.to_pose2d().x, q.pose.to_pose2d().y, q.pose.to_pose2d().theta))
            for q in poses] == [(1.0, 2.0, 0.5), (-2.2, 0.0, 3.0)]
    assert all(q.header.frame_id == "map" for q in poses)
    mission = json.loads(_req(srv, "/api/state")[1])["mission"]
    assert mission["active"] and mission["waypoints"] == [[1.0, 2.0, 0.5], [-2.2, 0.0, 3.0]]


def test_the_page_and_its_files_are_served_and_nothing_outside(server):
    srv, _ = server
    code, body = _req(srv, "/")
    assert code == 200 and b"2D Nav Goal" in body and b"Waypoints" in body
    assert _req(srv, "/app.js")[0] == 200
    assert _req(srv, "/../webserver.py")[0] == 404
    assert _req(srv, "/rerun/re_viewer.js")[0] == 404  # no assets given to this server
    assert json.loads(_req(srv, "/api/config")[1])["token_required"] is True


def test_the_particle_cloud_is_logged_as_arrows_with_its_covariance_ellipse(tmp_path):
    rec = rr.RecordingStream("zenav_test_particles")
    out = tmp_path / "p.rrd"
    rec.save(str(out))
    poses = np.column_stack((np.linspace(0, 1, 1000), np.zeros(1000), np.zeros(1000)))
    L.log_particles(rec, "world/particlecloud", m.Path(m.Header(1.0, "map"), poses))
    rec.flush()
    rec.disconnect()
    rows = read_rrd(out)
    arrows = values(rows["/world/particlecloud"], "Arrows3D:origins")
    assert arrows and 300 <= len(arrows[-1]) <= 400
    strips = values(rows["/world/particlecloud/covariance"], "LineStrips3D:strips")
    assert strips and len(strips[-1]) == 1


def test_the_map_view_is_fitted_again_only_when_the_map_no_longer_fits():
    from deploy.monitor.viewer import needs_fit

    room = (-3.3, -2.55, 3.3, 2.55)
    assert needs_fit(None, room)  # the first map
    assert not needs_fit(room, room)  # the same map logged again (keyframes, SLAM's updates)
    assert not needs_fit(room, (-3.0, -2.0, 3.0, 2.5))  # grown inside the view, or a little smaller
    assert needs_fit(room, (-4.3, -2.8, 4.3, 2.8))  # the demo's corridor, wider than the room
    assert needs_fit(room, (-3.3, -2.55, 3.3, 2.6))  # SLAM's map grew past the view
    assert needs_fit((-20.0, -20.0, 20.0, 20.0), room)  # another, much smaller world
