"""The map is not mirrored: ROS map frame +x right, +y up; a grid's row 0 is the lowest y, an image's row 0
(PGM, Rerun's GridMap, our page's map image) the top.

An asymmetric map (one block in the top-right quadrant, monhelp.asymmetric_grid) is checked
  - in what the monitor logs to Rerun (a real .rrd read back, placed the way Rerun's GridMap visualizer
    places an image: lower-left corner at the translation, row 0 at the far +y edge),
  - in what our page's map panel is sent (/api/map rows),
  - and on screen (slow, Chromium): the Rerun web viewer draws the block under a marker logged at the
    block's map coordinates, with +y up; our panel draws it dark where the block is and light at its mirror.
"""

from __future__ import annotations

import base64
import json
import time

import numpy as np
import pytest
import rerun as rr
from monhelp import asymmetric_grid, read_rrd

from common import messages as m
from common.geometry import Pose2D
from deploy.monitor.monitor import Monitor
from deploy.monitor.webstate import WebState
from testkit.check_web_viewer import find_chromium

# A leg driven now shows within this (seconds; the page redraws a few times a second with software
# rendering, and this recording is small): generous for a loaded CI machine, far below issue 31's minute.
LIVE_BOUND_S = 20.0


def image_cell(x: float, y: float, origin: tuple[float, float], res: float, h: int) -> tuple[int, int]:
    """(row, col) of map point (x, y) in an image of ``h`` rows whose row 0 is the top (highest y) and
    whose lower-left corner is at ``origin``."""
    col = int(np.floor((x - origin[0]) / res))
    return h - 1 - int(np.floor((y - origin[1]) / res)), col


def mirrors(grid: m.OccupancyGrid, p: tuple[float, float]) -> dict[str, tuple[float, float]]:
    """``p`` and its mirror images across the map's vertical / horizontal centre lines."""
    cx = grid.origin.x + grid.width * grid.resolution / 2
    cy = grid.origin.y + grid.height * grid.resolution / 2
    return {"block": p, "mirror_y": (p[0], 2 * cy - p[1]), "mirror_x": (2 * cx - p[0], p[1])}


def test_the_monitor_logs_grids_top_row_first_so_rerun_draws_them_unmirrored(tmp_path):
    grid, block = asymmetric_grid()
    costmap = m.Costmap(grid.header, grid.resolution, grid.origin, np.where(grid.data > 0, 254, 0).astype(np.uint8))
    rec = rr.RecordingStream("zenav_test_not_mirrored")
    out = tmp_path / "grid.rrd"
    rec.save(str(out))
    mon = Monitor(None, "r1", rec, subscribe=False)
    mon.handle("map", grid)
    mon.handle("global_costmap/costmap", costmap)
    mon.flush_pending(flush_all=True)
    rec.flush()
    rec.disconnect()
    rows = read_rrd(out)
    for entity, occupied in (("/world/map", 100), ("/world/global_costmap/costmap", 254)):
        row = next(r for r in rows[entity] if r.get("GridMap:data") is not None)
        fmt, res = row["GridMap:format"][0], row["GridMap:cell_size"][0]
        tx, ty, _ = row["GridMap:translation"][0]
        img = np.array(row["GridMap:data"][0], np.uint8).reshape(fmt["height"], fmt["width"])
        seen = {k: img[image_cell(*p, (tx, ty), res, fmt["height"])] for k, p in mirrors(grid, block).items()}
        assert seen == {"block": occupied, "mirror_y": 0, "mirror_x": 0}, (entity, seen)


def test_the_page_gets_the_map_image_top_row_first():
    grid, block = asymmetric_grid()
    st = WebState("r1")
    st.observe("map", grid)
    mp = st.map_payload()
    assert mp["rows"] == "top_first"
    img = np.frombuffer(base64.b64decode(mp["data"]), np.uint8).reshape(mp["height"], mp["width"])
    origin = (mp["origin"]["x"], mp["origin"]["y"])
    res, h = mp["resolution"], mp["height"]
    seen = {k: int(img[image_cell(*p, origin, res, h)]) for k, p in mirrors(grid, block).items()}
    assert seen == {"block": 0, "mirror_y": 254, "mirror_x": 254}, seen


def _centroid(mask: np.ndarray) -> tuple[float, float] | None:
    """(x, y) pixel centroid of ``mask`` (None below 20 pixels)."""
    ys, xs = np.nonzero(mask)
    return (float(xs.mean()), float(ys.mean())) if len(xs) > 20 else None


@pytest.mark.slow
@pytest.mark.skipif(find_chromium() is None, reason="chromium not installed (deploy/install.sh --test)")
def test_the_rerun_view_and_our_panel_show_the_block_where_it_is(tmp_path):
    """The real logging path (Monitor.handle, the monitor's blueprint fitted to the map) served to the
    Rerun web viewer inside our page; a green marker at the block's centre, a magenta one at its mirror
    across the horizontal centre line. In Rerun's map view the green marker sits on black (the block), the
    magenta on white, and green is above magenta (+y up). In our panel the block is dark, its mirrors light."""
    from deploy.monitor.layout import blueprint, fit_height
    from deploy.monitor.web_assets import ensure_assets
    from deploy.monitor.webserver import WebServer
    from testkit.webrig import Page, rerun_map_view, rgb
    from tests.support import free_port

    grid, block = asymmetric_grid()
    pts = mirrors(grid, block)
    w, h = grid.width * grid.resolution, grid.height * grid.resolution
    centre = (grid.origin.x + w / 2, grid.origin.y + h / 2)
    rec = rr.RecordingStream("zenav_test_not_mirrored_web")
    grpc = free_port()
    rec.serve_grpc(grpc_port=grpc, default_blueprint=blueprint(centre=centre, height=fit_height(w, h)))
    mon = Monitor(None, "r1", rec, subscribe=False)
    mon.handle("map", grid)
    mon.flush_pending(flush_all=True)
    for name, p, color in (("mark_block", pts["block"], [0, 255, 0]), ("mark_mirror", pts["mirror_y"], [255, 0, 255])):
        rec.log(f"world/{name}", rr.CoordinateFrame("map"), rr.Points3D([[*p, 0.2]], radii=0.12, colors=[color]),
                static=True)
    rec.flush()
    state = WebState("r1")
    state.observe("map", grid)
    srv = WebServer(state, lambda *_: None, free_port(), grpc, assets=ensure_assets())
    page = Page(tmp_path, srv.port)
    try:
        page.open_page(viewer=True)
        page.wait(lambda: page.js("!!(window.zenav && zenav.map && zenav.rerun !== 'starting')"), 150.0,
                  "the page with our map and the Rerun viewer")
        assert page.js("zenav.rerun") == "started", page.js("zenav.rerun")
        ours = {k: json.loads(page.js(f"JSON.stringify(zenav.worldToClient({x}, {y}))")) for k, (x, y) in pts.items()}
        split = int(json.loads(page.js("JSON.stringify(document.getElementById('rerun-panel')"
                                       ".getBoundingClientRect())"))["x"])

        def markers():
            img = rgb(page.screenshot())
            r, g, b = img[..., 0], img[..., 1], img[..., 2]
            right = np.zeros(r.shape, bool)
            right[:, split:] = True
            green = _centroid(right & (g > 180) & (r < 90) & (b < 90))
            magenta = _centroid(right & (r > 180) & (b > 180) & (g < 90))
            return (img, green, magenta) if green and magenta else None

        img, green, magenta = page.wait(markers, 150.0, "both markers drawn in Rerun's map view")
        (tmp_path / "not_mirrored.png").write_bytes(page.screenshot())
        assert green[1] < magenta[1] - 20, (green, magenta)  # +y is up on screen
        assert abs(green[0] - magenta[0]) < 10, (green, magenta)  # same x
        px_per_m = (magenta[1] - green[1]) / (pts["block"][1] - pts["mirror_y"][1])
        ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)

        def ring(c):  # brightness on a ring 0.3 m around a marker: inside the 1.6 x 1.2 m block, off the marker
            xs = (c[0] + 0.3 * px_per_m * np.cos(ang)).astype(int)
            ys = (c[1] + 0.3 * px_per_m * np.sin(ang)).astype(int)
            return float(np.median(img[ys, xs].mean(axis=1)))

        assert ring(green) < 60, f"Rerun draws no block under the marker at {pts['block']}: {ring(green)}"
        assert ring(magenta) > 200, f"Rerun draws something at the mirror {pts['mirror_y']}: {ring(magenta)}"
        bright = {k: float(img[int(c["y"]), int(c["x"])].mean()) for k, c in ours.items()}
        assert bright["block"] < 40 and bright["mirror_y"] > 200 and bright["mirror_x"] > 200, bright

        # The whole map in Rerun's map view (left of the local view, below the view's title, above the time panel)
        def to_screen(x: float, y: float) -> tuple[float, float]:
            return green[0] + (x - pts["block"][0]) * px_per_m, green[1] - (y - pts["block"][1]) * px_per_m

        view_left, _, view_right, _ = rerun_map_view(img, split)
        corners = [to_screen(grid.origin.x + i * w, grid.origin.y + j * h) for i in (0, 1) for j in (0, 1)]
        assert all(view_left < cx < view_right and 100 < cy < 0.75 * img.shape[0] for cx, cy in corners), \
            f"the map's corners {corners} not all inside the map view (x {view_left}..{view_right})"

        # The odometry trail, on screen where the robot drove: odom's poses through map -> odom, and nothing
        # where the simulator's ground truth (the map frame, set off on purpose) says it was.
        def trail_pixels() -> tuple[np.ndarray, np.ndarray]:
            img = rgb(page.screenshot())
            r, g, b = (img[..., k].astype(int) for k in range(3))
            ys, xs = np.nonzero((r > 200) & (g > 150) & (g < 230) & (b < 80))  # the trail's (250, 200, 0)
            keep = (xs > view_left) & (xs < view_right)  # the map view, not the local one
            return xs[keep], ys[keep]

        def near(xs, ys, path: np.ndarray, tol_px: float) -> np.ndarray:
            """Per pixel: within ``tol_px`` of the polyline ``path`` (map metres)."""
            pix = np.array([to_screen(*q) for q in path])
            best = np.full(len(xs), np.inf)
            for a, b in zip(pix[:-1], pix[1:]):
                ab = b - a
                t = np.clip(((xs - a[0]) * ab[0] + (ys - a[1]) * ab[1]) / (ab @ ab), 0.0, 1.0)
                best = np.minimum(best, np.hypot(xs - a[0] - t * ab[0], ys - a[1] - t * ab[1]))
            return best < tol_px

        odom_in_map = Pose2D(0.5, 0.0, 0.0)

        def drive(points, stamp0: float, truth=None) -> None:
            """odom (through map -> odom) at each map point; ground truth at ``truth``'s points if given."""
            for k, (x, y) in enumerate(points):
                h = m.Header(stamp0 + 0.1 * k, "map")
                mon.handle("tf", m.TFMessage((m.TransformStamped(h, "odom", odom_in_map.to_transform()),)))
                pose = Pose2D(x - odom_in_map.x, y - odom_in_map.y, 0.0).to_transform()
                mon.handle("odom", m.Odometry(m.Header(h.stamp, "odom"), "base_link", pose))
                if truth is not None:
                    mon.handle("ground_truth", m.Odometry(h, "base_link", Pose2D(*truth[k], 0.0).to_transform()))
                mon.flush_pending(flush_all=True)
            rec.flush()

        def along(line: np.ndarray, n: int) -> list:
            return [line[0] + (line[1] - line[0]) * f for f in np.linspace(0, 1, n)]

        path = np.array([(-2.0, -1.0), (1.0, -1.0), (1.0, 1.0)])  # map frame
        walk = along(path[:2], 31) + along(path[1:], 21)[1:]
        truth_line = np.array([(-2.0, 3.0), (0.0, 3.0)])  # where the ground truth topic says (not drawn)
        drive(walk, 1.0, truth=along(truth_line, len(walk)))
        tol = 0.12 * px_per_m

        def whole_trail():
            xs, ys = trail_pixels()
            ends = [np.hypot(xs - to_screen(*q)[0], ys - to_screen(*q)[1]).min(initial=np.inf) < tol for q in path]
            return (xs, ys) if len(xs) > 50 and all(ends) else None

        xs, ys = page.wait(whole_trail, 60.0, "the odometry trail drawn from its start to its end")
        (tmp_path / "trail.png").write_bytes(page.screenshot())
        on = near(xs, ys, path, tol)
        assert on.mean() > 0.98, (f"{(~on).sum()} of {len(xs)} trail pixels off the path the robot drove, e.g. "
                                  f"{list(zip(xs[~on][:5], ys[~on][:5]))} (see {tmp_path / 'trail.png'})")
        assert not near(xs, ys, truth_line, tol).any(), "a trail drawn where only the ground truth topic was"

        # Live: a leg driven now (stamped later than everything so far) is on screen within a bound; a view
        # that replays at 1x or follows an old time never shows it.
        leg = np.array([path[-1], (1.0, 2.0)])
        t_sent = time.monotonic()
        drive(along(leg, 11)[1:], 100.0)

        def leg_drawn():
            xs, ys = trail_pixels()
            end = to_screen(*leg[1])
            return np.hypot(xs - end[0], ys - end[1]).min(initial=np.inf) < tol

        page.wait(leg_drawn, 60.0, "the newest leg of the trail")
        shown_after = time.monotonic() - t_sent
        assert shown_after < LIVE_BOUND_S, f"the newest leg took {shown_after:.1f} s to show"
    finally:
        page.close()
        srv.close()
        rec.disconnect()
