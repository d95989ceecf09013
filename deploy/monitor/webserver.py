"""``zenav monitor --serve-web PORT``: our page around the Rerun web viewer, with rviz's tools.

Serves, on the address the user chose (``--bind``, default 127.0.0.1) only:
  GET  /                 the page (deploy/monitor/web/): the Rerun viewer (the wheel's own wasm build,
                         /rerun/...) plus a top-down map panel with the goal / initial pose tools
  GET  /api/config       robot, gRPC port of the recording, memory limit, whether a token is needed
  GET  /api/state        robot pose, AMCL pose / particles / covariance ellipse, plan, footprint, goal,
                         move_base state and the "why not moving" line (WebState.snapshot)
  GET  /api/map          the map as grey levels (WebState.map_payload)
  POST /api/goal         {"x", "y", "yaw"} -> a goal (map frame), acknowledged by move_base
  POST /api/initialpose  {"x", "y", "yaw"} -> an initial pose, acknowledged by AMCL
  POST /api/mission      {"waypoints": [{"x", "y", "yaw"}, ...], "loop": false} -> the waypoints driven one
                         after the other (deploy/stack/missions.py), a failed leg said and skipped; a new
                         mission replaces a running one; its progress is /api/state's "mission"
  POST /api/cancel       {} -> cancel (the mission too), acknowledged by move_base
  (each answers with what the node said, or 504 naming the node that did not answer in time)
POSTs need ``Content-Type: application/json`` (a cross-site form cannot send it) and, with ``--token``,
the header ``X-Zenav-Token`` (403 otherwise).
"""

from __future__ import annotations

import hmac
import json
import logging
import math
import mimetypes
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Callable

from deploy.monitor.webstate import WebState

log = logging.getLogger("zenav.monitor.web")
WEB_DIR = Path(__file__).resolve().parent / "web"
TYPES = {".js": "text/javascript", ".wasm": "application/wasm", ".html": "text/html; charset=utf-8",
         ".css": "text/css", ".png": "image/png"}
MAX_BODY = 16384
MAX_WAYPOINTS = 100


STATE_TOPICS = ("tf", "amcl_pose", "particlecloud", "move_base/status", "move_base/global_plan",
                "global_costmap/footprint", "collision_monitor/state", "move_base_simple/goal", "map")


def subscribe_state(session, robot: str, state: WebState) -> list:
    """Subscribers feeding ``state`` directly from the bus (not through the monitor's logging, which
    may lag behind on a loaded machine): only the few topics the page draws are decoded."""
    from common.codec import DecodeError, decode
    from common.latched_fetch import topic_key

    def handler(topic: str):
        def on_sample(sample) -> None:
            try:
                state.observe(topic, decode(sample.payload.to_bytes()))
            except DecodeError as e:
                log.debug("web state: bad %s: %s", topic, e)
        return on_sample

    return [session.declare_subscriber(topic_key(robot, t), handler(t)) for t in STATE_TOPICS]


class CommandNotAcknowledged(RuntimeError):
    """The node that should act on a command from the page did not answer in time (HTTP 504)."""


class WebServer:
    """``send(what, msg)`` hands a command from the page ("goal", "initialpose": a PoseStamped in the map
    frame; "mission": (a list of PoseStamped, loop); "cancel": None) to the robot's bus and returns the
    acting node's answer as one line of text; it raises ``CommandNotAcknowledged`` when that node did not
    answer, ``ValueError`` when it said no."""

    def __init__(self, state: WebState, send: Callable[[str, object], str], port: int, grpc_port: int,
                 bind: str = "127.0.0.1", token: str | None = None, memory_limit: str = "2GiB",
                 assets: Path | None = None) -> None:
        self.state, self.send, self.token = state, send, token or None
        self.config = {"robot": state.robot, "grpc_port": grpc_port, "memory_limit": memory_limit,
                       "token_required": bool(token), "map_frame": state.map_frame}
        self.assets = assets
        handler = type("Handler", (_Handler,), {"app": self})
        self.httpd = ThreadingHTTPServer((bind, port), handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True, name="monitor-web")
        self.thread.start()

    @property
    def port(self) -> int:
        return self.httpd.server_address[1]

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()

    # -- control -----------------------------------------------------------------------------------
    def control(self, what: str, body: dict) -> dict:
        from common.geometry import Pose2D
        from common.messages import Header, PoseStamped

        if what == "cancel":
            answer = self.send("cancel", None)
            self.state.note(f"cancel: {answer}")
            return {"ok": True, "answer": answer}
        if what == "mission":
            wps = body.get("waypoints")
            if not isinstance(wps, list) or not 0 < len(wps) <= MAX_WAYPOINTS:
                raise ValueError(f"expected waypoints: a list of 1 to {MAX_WAYPOINTS} {{x, y, yaw}}")
            poses = [_pose(w, f"waypoint {i + 1}: ") for i, w in enumerate(wps)]
            loop = body.get("loop", False)
            if not isinstance(loop, bool):
                raise ValueError("loop must be true or false")
            msgs = [PoseStamped(Header(0.0, self.state.map_frame), Pose2D(*p).to_transform()) for p in poses]
            self.state.mission_line(f"starting ({len(poses)} waypoints)", True, [list(p) for p in poses])
            try:
                answer = self.send("mission", (msgs, loop))
            except Exception as e:
                self.state.mission_line(f"not started: {e}", False)
                raise
            self.state.note(f"mission of {len(poses)} waypoints{' (loop)' if loop else ''}: {answer}")
            return {"ok": True, "answer": answer, "waypoints": len(poses)}
        x, y, yaw = _pose(body)
        msg = PoseStamped(Header(0.0, self.state.map_frame), Pose2D(x, y, yaw).to_transform())
        answer = self.send(what, msg)
        self.state.note(f"{what} ({x:.2f}, {y:.2f}, {math.degrees(yaw):.0f} deg): {answer}")
        log.info("web page: %s (%.2f, %.2f, %.2f): %s", what, x, y, yaw, answer)
        return {"ok": True, "answer": answer, "x": x, "y": y, "yaw": yaw}


def _pose(body, where: str = "") -> tuple[float, float, float]:
    try:
        x, y, yaw = (float(body[k]) for k in ("x", "y", "yaw"))
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}expected numbers x, y, yaw") from None
    if not all(map(math.isfinite, (x, y, yaw))):
        raise ValueError(f"{where}x, y, yaw must be finite")
    return x, y, yaw


class _Handler(BaseHTTPRequestHandler):
    app: WebServer
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt, *args) -> None:  # quiet: one debug line per request
        log.debug("%s %s", self.address_string(), fmt % args)

    def _send(self, code: int, body: bytes, ctype: str, cache: bool = False) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "max-age=3600" if cache else "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, code: int, obj) -> None:
        self._send(code, json.dumps(obj).encode(), "application/json")

    def do_GET(self) -> None:  # noqa: N802 - http.server's naming
        path = self.path.split("?", 1)[0]
        app = self.app
        if path == "/api/config":
            return self._json(200, app.config)
        if path == "/api/state":
            return self._json(200, app.state.snapshot())
        if path == "/api/map":
            payload = app.state.map_payload()
            return self._json(200 if payload else 404, payload or {"error": "no map yet"})
        if path in ("/", "/index.html"):
            path = "/index.html"
        if path.startswith("/rerun/"):
            if app.assets is None:
                return self._json(404, {"error": "the Rerun viewer files are not available"})
            return self._file(app.assets, path[len("/rerun/"):] or "index.html", cache=True)
        return self._file(WEB_DIR, path.lstrip("/"))

    do_HEAD = do_GET

    def _file(self, root: Path, name: str, cache: bool = False) -> None:
        f = (root / name).resolve()
        if root.resolve() not in f.parents or not f.is_file():
            return self._json(404, {"error": "not found"})
        ctype = TYPES.get(f.suffix) or mimetypes.guess_type(f.name)[0] or "application/octet-stream"
        return self._send(200, f.read_bytes(), ctype, cache)

    def do_POST(self) -> None:  # noqa: N802
        path = self.path.split("?", 1)[0]
        what = path.removeprefix("/api/")
        if what not in ("goal", "initialpose", "cancel", "mission"):
            return self._json(404, {"error": "not found"})
        token = self.app.token
        if token and not hmac.compare_digest(self.headers.get("X-Zenav-Token", ""), token):
            return self._json(403, {"error": "missing or wrong token (X-Zenav-Token)"})
        if not self.headers.get("Content-Type", "").startswith("application/json"):
            return self._json(415, {"error": "Content-Type must be application/json"})
        n = int(self.headers.get("Content-Length") or 0)
        if n > MAX_BODY:
            return self._json(413, {"error": "body too large"})
        try:
            body = json.loads(self.rfile.read(n) or b"{}")
            return self._json(200, self.app.control(what, body if isinstance(body, dict) else {}))
        except ValueError as e:
            return self._json(400, {"error": str(e)})
        except CommandNotAcknowledged as e:
            self.app.state.note(f"{what}: {e}")
            return self._json(504, {"error": str(e)})
        except Exception as e:  # noqa: BLE001 - the bus may be closing
            log.warning("web control %s failed: %s", what, e)
            return self._json(500, {"error": str(e)})
