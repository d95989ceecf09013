"""The page's map panel view in headless Chromium (no simulator: an in-process WebServer fed a map and TF).

A 40 x 30 m map, larger than the panel shows: the view follows the robot by default (centred on it, clamped
at the map's edges), "Follow robot" off fixes it, + zooms, dragging without a tool pans (and stops
following), and a goal clicked with the tool lands on the clicked map point whatever the view is. A map
smaller than the default span is shown whole.
"""

from __future__ import annotations

import json
import math

import pytest
from monhelp import asymmetric_grid

from common import messages as m
from common.geometry import Pose2D
from deploy.monitor.webserver import WebServer
from deploy.monitor.webstate import WebState
from testkit.check_web_viewer import find_chromium


def _robot_at(state: WebState, x: float, y: float, yaw: float = 0.0) -> None:
    state.observe("tf", m.TFMessage([m.TransformStamped(m.Header(1.0, "map"), "base_link",
                                                        Pose2D(x, y, yaw).to_transform())]))


@pytest.mark.slow
@pytest.mark.skipif(find_chromium() is None, reason="chromium not installed (deploy/install.sh --test)")
def test_the_panel_follows_the_robot_can_be_fixed_zoomed_panned_and_clicks_land_on_the_map(tmp_path):
    from testkit.webrig import Page

    big, _ = asymmetric_grid(40.0, 30.0, 0.1, (-20.0, -15.0))
    state, sent = WebState("r1"), []
    state.observe("map", big)
    _robot_at(state, 2.0, 1.0)
    srv = WebServer(state, lambda what, msg: sent.append((what, msg.pose.to_pose2d())) or "taken", 0, 9876)
    page = Page(tmp_path, srv.port)

    def info() -> dict:
        return json.loads(page.js("JSON.stringify(zenav.viewInfo())"))

    def centred_on(x: float, y: float):
        return lambda: (v := info()) and abs(v["cx"] - x) < 1e-3 and abs(v["cy"] - y) < 1e-3 and v

    def click_goal(x: float, y: float, yaw: float) -> Pose2D:
        n = len(sent)
        page.use_tool("goal", x, y, yaw)
        page.wait(lambda: len(sent) > n, 10.0, "the page sending the goal")
        topic, p = sent[-1]
        assert topic == "goal"
        assert math.hypot(p.x - x, p.y - y) < 0.05 and abs(math.remainder(p.theta - yaw, 2 * math.pi)) < 0.1, (p, x, y)
        return p

    try:
        page.open_page(viewer=False)
        page.wait(lambda: page.js("!!(window.zenav && zenav.map && zenav.state && zenav.state.pose)"), 60.0,
                  "the page with the map and the robot")
        # 1. following by default: centred on the robot, about 12 m across the panel's shorter side
        v = page.wait(centred_on(2.0, 1.0), 10.0, "the view centred on the robot")
        assert v["following"] and not v["whole"], v
        rect = json.loads(page.js("JSON.stringify(document.getElementById('map').getBoundingClientRect())"))
        assert min(rect["width"], rect["height"]) / v["s"] == pytest.approx(12.0, rel=0.02)
        robot = json.loads(page.js("JSON.stringify(zenav.worldToClient(2, 1))"))
        assert robot["x"] == pytest.approx(rect["x"] + rect["width"] / 2, abs=1)
        assert robot["y"] == pytest.approx(rect["y"] + rect["height"] / 2, abs=1)
        click_goal(4.0, 3.0, math.pi / 2)
        # the robot moves: the view goes with it; near a corner the map's edge stays at the panel's edge
        _robot_at(state, 6.0, -3.0)
        page.wait(centred_on(6.0, -3.0), 10.0, "the view following the robot")
        _robot_at(state, -19.5, -14.5)
        page.wait(lambda: page.js("zenav.state.pose.x") == -19.5, 10.0, "the page seeing the robot move")
        assert -19.0 < info()["cx"] < 0.0, info()  # clamped: the map's corner, not the robot, at the edge
        corner = json.loads(page.js("JSON.stringify(zenav.worldToClient(-20, -15))"))
        assert corner["x"] == pytest.approx(rect["x"], abs=1) and corner["y"] == pytest.approx(
            rect["y"] + rect["height"], abs=1), corner
        click_goal(-17.0, -12.0, 0.0)

        # 2. "Follow robot" off: the view stays where it is while the robot moves; zoom in; a click still lands
        _robot_at(state, 0.0, 0.0)
        page.wait(centred_on(0.0, 0.0), 10.0, "the view following the robot")
        page.click_element("follow")
        _robot_at(state, 5.0, 5.0)
        page.wait(lambda: page.js("zenav.state.pose.x") == 5.0, 10.0, "the page seeing the robot move")
        v = info()
        assert not v["follow"] and (v["cx"], v["cy"]) == pytest.approx((0.0, 0.0), abs=1e-3), v
        s0 = v["s"]
        page.click_element("zoom-in")
        assert info()["s"] == pytest.approx(1.25 * s0)
        click_goal(1.0, -2.0, -math.pi / 2)
        # back on: centred on the robot again
        page.click_element("follow")
        page.wait(centred_on(5.0, 5.0), 10.0, "the view following the robot again")

        # 3. dragging the map without a tool pans it (and stops following): 100 px right = the map moves right
        a = (rect["x"] + rect["width"] / 2, rect["y"] + rect["height"] / 2)
        s = info()["s"]
        page.mouse("mouseMoved", *a, 0)
        page.mouse("mousePressed", *a)
        for k in range(1, 6):
            page.mouse("mouseMoved", a[0] + 20 * k, a[1])
        page.mouse("mouseReleased", a[0] + 100, a[1])
        v = info()
        assert not v["follow"] and v["cx"] == pytest.approx(5.0 - 100 / s, abs=0.02) and v["cy"] == pytest.approx(5.0)
        click_goal(3.0, 4.0, math.pi)

        # 4. a map smaller than the default span is shown whole (following changes nothing)
        small, _ = asymmetric_grid(6.0, 4.5, 0.05, (-3.0, -2.25))
        state.observe("map", small)
        page.click_element("zoom-out")  # back to the default scale (1.25 x 0.8)
        page.click_element("follow")
        _robot_at(state, -2.0, 0.0)
        page.wait(lambda: page.js("zenav.map.width") == small.width, 10.0, "the page loading the new map")
        v = page.wait(lambda: (v := info())["whole"] and v, 10.0, "the small map shown whole")
        assert (v["cx"], v["cy"]) == pytest.approx((0.0, 0.0), abs=1e-6), v
        click_goal(1.5, 1.0, 0.0)
    finally:
        page.close()
        srv.close()
