"""Rig for the web page tests: simulated P3-AT + master (AMCL, move_base) + `zenav monitor --serve-web`
on a private loopback bus (``WebRig``), and headless Chromium driven over the DevTools protocol on the page
(``Page``, testkit.cdp)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import yaml

from testkit.cdp import CDP
from testkit.check_web_viewer import find_chromium
from testkit.nav_stack import MASTER_DIR, ROBOT_CONFIG, NavProc, absolute_param_paths
from testkit.wait import free_port, wait_until

REPO = Path(__file__).resolve().parents[1]
ZENAV = [sys.executable, "-m", "deploy.cli"]  # this checkout's code, whatever `zenav` on PATH is


def master_yaml(tmp: Path, initial: tuple[float, float, float]) -> Path:
    """p3at_amcl.yaml (map server, AMCL, costmaps, move_base) with absolute paths, the room's map and
    AMCL's initial pose set to ``initial`` (the test starts it wrong on purpose)."""
    from deploy.stack.world_maps import export_world_map

    src = MASTER_DIR / "p3at_amcl.yaml"
    cfg = yaml.safe_load(src.read_text())
    absolute_param_paths(cfg, src.parent)
    cfg["nodes"]["map_server"]["params"]["map"] = str(export_world_map("room", tmp / "maps"))
    loc = cfg["nodes"]["localization"]["params"]
    loc["initial_pose_x"], loc["initial_pose_y"], loc["initial_pose_a"] = initial
    # a tight cloud around the wrong pose: with the config's 0.25 m spread, some particles lie near the
    # truth and the first scan can pull the estimate there before the test looks (a CI run did)
    loc["initial_cov_xx"] = loc["initial_cov_yy"] = 0.05 ** 2
    loc["initial_cov_aa"] = 0.05 ** 2
    out = tmp / "master_web.yaml"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


class Page:
    """Headless Chromium driven over the DevTools protocol, on the monitor page served at ``web``."""

    def __init__(self, tmp: Path, web: int, token: str = "") -> None:
        self.web, self.token, self.devtools = web, token, free_port()
        self.chromium = subprocess.Popen(
            [find_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--disable-dev-shm-usage", f"--remote-debugging-port={self.devtools}", "--window-size=1600,900",
             f"--user-data-dir={tmp / 'chromium'}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.cdp: CDP | None = None

    def wait(self, cond, timeout: float, what: str):
        return wait_until(cond, timeout, what, period=0.2)

    def open_page(self, viewer: bool = True) -> None:
        import urllib.request

        def up() -> bool:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{self.web}/api/config", timeout=2):
                    return True
            except OSError:
                return False

        self.wait(up, 90.0, "the monitor's page")
        if self.cdp is None:
            self.cdp = CDP.connect(self.devtools)
        # the Rerun viewer's wasm shares the page's main thread: while it compiles and starts (and on a
        # loaded machine) an evaluation may wait tens of seconds
        self.cdp.timeout = 150.0
        self.cdp.ws.sock.settimeout(150.0)
        self.cdp.call("Page.navigate", url=f"http://127.0.0.1:{self.web}/?token={self.token}"
                                            + ("" if viewer else "&viewer=0"))

    def js(self, expr: str):
        r = self.cdp.call("Runtime.evaluate", expression=expr, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expr}: {r['exceptionDetails']}")
        return r.get("result", {}).get("value")

    def mouse(self, kind: str, x: float, y: float, buttons: int = 1) -> None:
        self.cdp.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left",
                      buttons=buttons if kind != "mouseReleased" else 0, clickCount=1)

    def click_element(self, element_id: str) -> None:
        r = self.js(f"JSON.stringify(document.getElementById('{element_id}').getBoundingClientRect())")
        box = json.loads(r)
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        self.mouse("mouseMoved", x, y, 0)
        self.mouse("mousePressed", x, y)
        self.mouse("mouseReleased", x, y)

    def use_tool(self, tool: str, x: float, y: float, yaw: float, drag_m: float = 0.6, select: bool = True) -> None:
        """Select ``tool`` (its button; ``select=False``: it is still selected, as the waypoint tool stays),
        press at map point (x, y), drag ``drag_m`` along ``yaw``, release: real mouse events, as a user
        does. Both points convert through the view shown at the press."""
        if select:
            self.click_element(f"tool-{tool}")
        a = self.js(f"JSON.stringify(zenav.worldToClient({x}, {y}))")
        b = self.js(f"JSON.stringify(zenav.worldToClient({x + drag_m * np.cos(yaw)}, {y + drag_m * np.sin(yaw)}))")
        a, b = json.loads(a), json.loads(b)
        self.mouse("mouseMoved", a["x"], a["y"], 0)
        self.mouse("mousePressed", a["x"], a["y"])
        for t in np.linspace(0.2, 1.0, 5):
            self.mouse("mouseMoved", a["x"] + t * (b["x"] - a["x"]), a["y"] + t * (b["y"] - a["y"]))
        self.mouse("mouseReleased", b["x"], b["y"])

    def screenshot(self) -> bytes:
        return self.cdp.screenshot()

    def close(self) -> None:
        if self.cdp is not None:
            self.cdp.close()
        self.chromium.terminate()
        try:
            self.chromium.wait(10)
        except subprocess.TimeoutExpired:
            self.chromium.kill()
        with contextlib.suppress(ProcessLookupError, PermissionError):  # its helpers (own session: own group)
            os.killpg(self.chromium.pid, signal.SIGKILL)


class WebRig(Page):
    def __init__(self, tmp: Path, amcl_initial: tuple[float, float, float], token: str) -> None:
        from common.bus import Node
        from common.messages import MoveBaseStatus, Odometry, PoseStamped
        from common.zenoh_config import BusConfig

        self.tmp, self.procs = tmp, []
        self.robot = f"web{uuid.uuid4().hex[:10]}"
        test_port, robot_port, master_port, mon_port = free_port(), free_port(), free_port(), free_port()
        web, self.grpc = free_port(), free_port()
        self.node = Node("web_tools_test", config=BusConfig(robot=self.robot, listen=(f"tcp/127.0.0.1:{test_port}",),
                                                            multicast=False), use_sim_time=False)
        base = {**os.environ, "ZENAV_ROBOT": self.robot, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
                "PYTHONPATH": str(REPO)}
        base.pop("ZENAV_USE_SIM_TIME", None)
        hub = f"tcp/127.0.0.1:{test_port}"
        self.gt = self.node.subscribe("ground_truth", Odometry)
        self.amcl = self.node.subscribe("amcl_pose", PoseStamped)
        self.status = self.node.subscribe("move_base/status", MoveBaseStatus)
        self.start("robot", [*ZENAV, "robot", "--config", str(ROBOT_CONFIG), "--world", "room"],
                   {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{robot_port}", "ZENAV_CONNECT": hub})
        self.start("master", [*ZENAV, "master", "--config", str(master_yaml(tmp, amcl_initial))],
                   {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{master_port}",
                    "ZENAV_CONNECT": f"{hub},tcp/127.0.0.1:{robot_port}"})
        self.start("monitor", [*ZENAV, "monitor", "--serve-web", str(web), "--grpc-port", str(self.grpc),
                               "--token", token],
                   {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{mon_port}", "ZENAV_CONNECT": hub})
        super().__init__(tmp, web, token)

    def start(self, name: str, argv: list[str], env: dict) -> NavProc:
        p = NavProc(self.tmp / f"{name}.log", argv, env)
        self.procs.append(p)
        return p

    def dead(self) -> str:
        return next((f"{p.log_path.name} exited:\n{p.log()}" for p in self.procs if not p.alive()), "")

    def wait(self, cond, timeout: float, what: str):
        return wait_until(cond, timeout, what, period=0.2, alive=self.dead)

    def close(self) -> None:
        super().close()
        for p in reversed(self.procs):
            p.stop()
        self.node.close()


def rgb(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def rerun_map_view(img: np.ndarray, split: int | None = None) -> tuple[int, int, int, int]:
    """Rerun's map view (x0, y0, x1, y1) in a screenshot of the page: right of our panel (``split``: the
    Rerun panel's left edge; style.css makes our panel 44 % wide), the blueprint's first column (3 of 5 of
    the viewer's width: deploy/monitor/layout.py), below the 41 px bar, Rerun's top bar and the view's title."""
    h, w = img.shape[:2]
    split = int(0.44 * w) if split is None else split
    return split + 4, 41 + 60, split + int(0.6 * (w - split)) - 4, h - 50


def map_mask(img: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """The pixels of ``box`` (x0, y0, x1, y1) in the map's colours: free (white / light grey), unknown (our
    panel's grey, Rerun's grey-green), the costmap's yellow band. Walls are thin and left out (black is
    also close to the dark background)."""
    x0, y0, x1, y1 = box
    c = img[y0:y1, x0:x1]
    r, g, b = c[..., 0], c[..., 1], c[..., 2]
    free = (r > 200) & (g > 200) & (b > 200)
    grey = (np.abs(r - 128) < 12) & (np.abs(g - 128) < 12) & (np.abs(b - 128) < 12)
    unknown = (np.abs(r - 110) < 15) & (np.abs(g - 126) < 15) & (np.abs(b - 124) < 15)
    yellow = (r > 200) & (g > 180) & (b < 120)
    return free | grey | unknown | yellow


def map_fraction(img: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """Share of the pixels of ``box`` in the map's colours (``map_mask``)."""
    return float(map_mask(img, box).mean())


def map_extent(img: np.ndarray, box: tuple[int, int, int, int]) -> tuple[float, float]:
    """How much of ``box``'s width and height the map spans: the share of its columns and of its rows in
    which at least a fifth of the pixels are in the map's colours."""
    mask = map_mask(img, box)
    return float((mask.mean(axis=0) > 0.2).mean()), float((mask.mean(axis=1) > 0.2).mean())
