"""`zenav monitor --serve-web`: the page's tools drive a simulated robot, in headless Chromium.

One browser session against one simulated stack (P3-AT in the room, map server + AMCL + move_base, the
monitor), real mouse events over the DevTools protocol:
  1. AMCL starts 0.8 m off the truth; "2D Pose Estimate" at the true pose: the estimate jumps there;
  2. "2D Nav Goal" at a free point: the simulated robot reaches it (ground truth);
  3. "Waypoints": two queued by clicks (a quarter turn there, then 0.4 m on), "Go": both legs reached;
  4. a screenshot: the map fills most of our map panel.
``ZENAV_DOCS_SHOTS=1`` reloads the page with the Rerun viewer, checks that the map fills most of Rerun's map
view too, and writes that screenshot to docs/monitor-web.png (the README's picture).
"""

from __future__ import annotations

import json
import math
import os
import time
import urllib.error
import urllib.request

import pytest

from testkit.check_web_viewer import find_chromium
from testkit.webrig import REPO, WebRig, map_extent, map_fraction, rgb

START = (-2.2, 0.0, 0.0)  # robot_side/worlds/room.yaml
AMCL_WRONG = (-1.5, 0.5, 0.4)
GOAL = (-1.0, 1.3, math.pi / 2)  # free: left of the crate at (0, 0)
WAYPOINTS = [(-1.0, 1.3, 0.0), (-0.6, 1.3, 0.0)]  # from GOAL: a quarter turn in place, then 0.4 m on
# Ground truth within the planner's xy_goal_tolerance (0.3 m) of a goal reached, plus AMCL's error: move_base
# applies the tolerance to AMCL's estimate (up to 0.071 m off on the room route, README "The tutorial on
# physics"). With 0.3 alone, a goal reached with the estimate inside the tolerance failed at 0.302 m of truth.
REACHED_M = 0.3 + 0.1


def _post(port: int, path: str, token: str | None, body: dict, ctype: str = "application/json") -> int:
    headers = {"Content-Type": ctype}
    if token is not None:
        headers["X-Zenav-Token"] = token
    req = urllib.request.Request(f"http://127.0.0.1:{port}{path}", json.dumps(body).encode(), headers)
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


@pytest.mark.slow
@pytest.mark.skipif(find_chromium() is None, reason="chromium not installed (deploy/install.sh --test)")
def test_the_page_sets_the_initial_pose_and_a_goal_and_shows_the_map(tmp_path):
    t0 = time.monotonic()
    rig = WebRig(tmp_path, AMCL_WRONG, token="s3cret")
    try:
        rig.open_page(viewer=False)  # the tools alone first: the viewer's wasm is heavy on this machine
        # the control endpoints: no / wrong token -> 403; a form post -> 415 (nothing published)
        assert _post(rig.web, "/api/goal", None, {"x": 0, "y": 0, "yaw": 0}) == 403
        assert _post(rig.web, "/api/goal", "wrong", {"x": 0, "y": 0, "yaw": 0}) == 403
        assert _post(rig.web, "/api/cancel", "s3cret", {}, "application/x-www-form-urlencoded") == 415
        rig.wait(lambda: rig.js("!!(window.zenav && zenav.map && zenav.state && zenav.state.pose "
                                 "&& zenav.state.move_base)"),
                 120.0, "the page showing the map, the robot and move_base")
        link = rig.wait(lambda: (t := rig.js("document.getElementById('link').textContent")).startswith("● live")
                        and t, 30.0, "the page's link state live")
        assert rig.robot in link, link
        rig.wait(lambda: rig.amcl.latest() is not None, 30.0, "amcl_pose")
        before = rig.amcl.latest().pose.to_pose2d()
        assert math.hypot(before.x - START[0], before.y - START[1]) > 0.4, before
        t_setup = time.monotonic() - t0

        # 1. 2D Pose Estimate at the truth: AMCL's estimate jumps to the clicked pose
        truth = rig.gt.latest().pose2d
        rig.use_tool("initialpose", truth.x, truth.y, truth.theta)
        sent = rig.wait(lambda: rig.js("zenav.sent.length ? JSON.stringify(zenav.sent[0]) : ''"), 10.0,
                        "the page sending the initial pose")
        sent = json.loads(sent)
        assert sent["tool"] == "initialpose"
        assert math.hypot(sent["x"] - truth.x, sent["y"] - truth.y) < 0.05, (sent, truth)
        assert abs(math.remainder(sent["yaw"] - truth.theta, 2 * math.pi)) < 0.1, (sent, truth)

        def jumped():
            p = rig.amcl.latest().pose.to_pose2d()
            return (math.hypot(p.x - sent["x"], p.y - sent["y"]) < 0.15
                    and abs(math.remainder(p.theta - sent["yaw"], 2 * math.pi)) < 0.15) and p
        est = rig.wait(jumped, 20.0, "amcl_pose at the clicked initial pose")
        t_pose = time.monotonic() - t0

        # 2. 2D Nav Goal at a free point: the robot gets there (ground truth)
        rig.use_tool("goal", *GOAL)
        rig.wait(lambda: rig.js("zenav.sent.length > 1"), 10.0, "the page sending the goal")
        goal = json.loads(rig.js("JSON.stringify(zenav.sent[1])"))
        assert goal["tool"] == "goal" and math.hypot(goal["x"] - GOAL[0], goal["y"] - GOAL[1]) < 0.05, goal
        rig.wait(lambda: (s := rig.status.latest()) is not None and s.status == 3 and s.state == "IDLE"
                 and s.goal.pose.to_pose2d().x == pytest.approx(goal["x"], abs=1e-6), 90.0,
                 "move_base reporting the page's goal SUCCEEDED")
        end = rig.gt.latest().pose2d
        reach = math.hypot(end.x - goal["x"], end.y - goal["y"])
        assert reach < REACHED_M, (end, goal)
        t_goal = time.monotonic() - t0
        state = json.loads(rig.js("JSON.stringify(zenav.state.move_base)"))
        assert state["status"] in ("SUCCEEDED", "ACTIVE", "PENDING"), state

        # 3. the waypoint queue: the tool stays selected for the second click; Go sends both as one mission
        for k, wp in enumerate(WAYPOINTS):
            rig.use_tool("waypoint", *wp, select=k == 0)
        rig.wait(lambda: rig.js("zenav.queue.length") == 2, 10.0, "two waypoints queued on the page")
        rig.click_element("mission-go")
        line = rig.wait(lambda: (m := rig.js("zenav.state && zenav.state.mission && !zenav.state.mission.active "
                                             "? zenav.state.mission.line : ''")) and m, 120.0,
                        "the page's mission ending")
        assert line == "mission: 2 of 2 legs reached", line  # the last line, as the bar shows it
        end = rig.gt.latest().pose2d
        assert math.hypot(end.x - WAYPOINTS[1][0], end.y - WAYPOINTS[1][1]) < REACHED_M, end
        t_mission = time.monotonic() - t0

        # 4. the screenshot: our map panel is mostly map. The Rerun viewer in the page is checked on screen by
        # tests/monitor/test_monitor_not_mirrored.py (a known grid and marker); loading it here, beside a whole
        # stack, took 30-180 s of a loaded CI machine for a check that tolerated a view a minute behind (issue
        # 31: the view must be live, and its test will bound that). ZENAV_DOCS_SHOTS=1 still shoots the whole
        # page with the viewer for the README.
        png = rig.screenshot()
        img = rgb(png)
        panel = _our_panel(img, 1.0)  # the panel alone spans the page: the map fits one way
        extent, f_ours = map_extent(img, panel), map_fraction(img, panel)
        f_rerun = None
        if os.environ.get("ZENAV_DOCS_SHOTS"):
            png, f_ours, f_rerun = _with_viewer(rig)
            (REPO / "docs" / "monitor-web.png").write_bytes(png)
        (tmp_path / "monitor-web.png").write_bytes(png)
        rerun = "" if f_rerun is None else f", {100 * f_rerun:.0f} % of Rerun's map view"
        print(f"\nweb tools: setup {t_setup:.0f} s, initial pose applied at {t_pose:.0f} s (amcl "
              f"({est.x:.2f}, {est.y:.2f}, {est.theta:.2f})), goal reached at {t_goal:.0f} s ({reach:.2f} m "
              f"off), mission at {t_mission:.0f} s, map spans {100 * extent[0]:.0f} % x {100 * extent[1]:.0f} % "
              f"of our panel (fills "
              f"{100 * f_ours:.0f} %){rerun}; screenshot {tmp_path / 'monitor-web.png'}")
        # fitted: edge to edge one way, not both (zoomed in) and not a sliver
        assert max(extent) > 0.9 and 0.3 < min(extent) < 0.98, extent
        assert f_rerun is None or (f_ours > 0.6 and f_rerun > 0.6), (f_ours, f_rerun)
    finally:
        rig.close()


def _our_panel(img, share: float) -> tuple[int, int, int, int]:
    """Our map panel's box in a screenshot (style.css: a 41 px bar; ``share`` of the width: 0.44 beside the
    viewer, 1.0 without it)."""
    h, w = img.shape[:2]
    return 4, 45, int(share * w) - 4, h - 30


def _with_viewer(rig: WebRig) -> tuple[bytes, float, float]:
    """The page reloaded with the Rerun viewer; once both panels show the map (or 120 s): the screenshot
    and the map's share of our panel and of Rerun's map view."""
    rig.open_page(viewer=True)
    rig.wait(lambda: rig.js("!!(window.zenav && zenav.map && zenav.state && zenav.rerun !== 'starting')"), 150.0,
             "the page with the Rerun viewer")
    assert rig.js("zenav.rerun") == "started", rig.js("zenav.rerun")

    def fractions() -> tuple[bytes, float, float]:
        png = rig.screenshot()
        img = rgb(png)
        # the page's geometry (style.css: 41 px bar, map panel 44 % wide); no script evaluation here: the
        # running viewer can keep the page's main thread busy for long on a loaded machine
        h, w = img.shape[:2]
        split = int(0.44 * w)
        o = _our_panel(img, 0.44)
        # Rerun's map view: the left 3/5 of its canvas, below its top bar and view title, above the time panel
        r = (split + 10, 41 + 80, split + int(0.6 * (w - split)) - 10, h - 60)
        return png, map_fraction(img, o), map_fraction(img, r)

    deadline = time.monotonic() + 120.0
    png, f_ours, f_rerun = fractions()
    while (f_ours <= 0.6 or f_rerun <= 0.6) and time.monotonic() < deadline:
        time.sleep(2.0)
        png, f_ours, f_rerun = fractions()
    return png, f_ours, f_rerun
