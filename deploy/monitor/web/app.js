// zenav monitor page: the Rerun web viewer (right) and a top-down map panel with rviz's tools (left).
// The map panel is drawn from /api/map and /api/state; clicks become POSTs to /api/goal, /api/initialpose.
// Its view (view.js) follows the robot by default; every click converts through the view being drawn.
"use strict";

const Z = (window.zenav = {
  tool: null, map: null, mapImage: null, state: null, config: null, drag: null,
  viewerEvents: [], rerun: "starting", sent: [], queue: [], loop: false,
});
const token = new URLSearchParams(location.search).get("token") || "";
const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");

async function post(path, body) {
  const headers = { "Content-Type": "application/json" };
  if (token) headers["X-Zenav-Token"] = token;
  const r = await fetch(path, { method: "POST", headers, body: JSON.stringify(body || {}) });
  const out = await r.json().catch(() => ({}));
  if (!r.ok) throw new Error(out.error || `HTTP ${r.status}`);
  return out;
}

function note(text) { document.getElementById("note").textContent = text; }

// -- view (view.js): follows the robot by default; "Follow robot" off fixes it; zoom; drag to pan ---
Z.follow = true; Z.zoom = 1; Z.centre = null;
function view() {
  if (!Z.map) return null;
  if (Z.frozen) return Z.frozen;  // a tool drag in progress: the view under the mouse stays put
  const rect = canvas.getBoundingClientRect();
  const v = ZenavView.make(rect, Z.map, { zoom: Z.zoom, follow: Z.follow, centre: Z.centre,
                                          pose: Z.state && Z.state.pose });
  v.rect = rect;
  return v;
}
const toCanvas = ZenavView.toCanvas, toWorld = ZenavView.toWorld;
Z.worldToClient = (x, y) => {
  const v = view();
  if (!v) return null;
  const [cx, cy] = toCanvas(v, x, y);
  return { x: v.rect.left + cx, y: v.rect.top + cy };
};
Z.clientToWorld = (px, py) => {
  const v = view();
  return v ? toWorld(v, px - v.rect.left, py - v.rect.top) : null;
};
Z.viewInfo = () => {
  const v = view();
  return v && { s: v.s, cx: v.cx, cy: v.cy, following: v.following, whole: v.whole, follow: Z.follow, zoom: Z.zoom };
};
function setFollow(on) {
  const v = view();
  if (!on && v) Z.centre = [v.cx, v.cy];  // fix the view where it is now
  Z.follow = on;
  document.getElementById("follow").classList.toggle("active", on);
  draw();
}
function zoom(factor) { Z.zoom = ZenavView.zoomBy(Z.zoom, factor); draw(); }

// -- drawing -------------------------------------------------------------------------------------
function arrow(v, p, color, len) {
  const [x, y] = toCanvas(v, p.x, p.y);
  const L = Math.max(len * v.s, 14);
  const ex = x + L * Math.cos(p.yaw), ey = y - L * Math.sin(p.yaw);
  ctx.strokeStyle = ctx.fillStyle = color; ctx.lineWidth = 3;
  ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(ex, ey); ctx.stroke();
  const a = Math.atan2(ey - y, ex - x);
  ctx.beginPath(); ctx.moveTo(ex, ey);
  ctx.lineTo(ex - 9 * Math.cos(a - 0.45), ey - 9 * Math.sin(a - 0.45));
  ctx.lineTo(ex - 9 * Math.cos(a + 0.45), ey - 9 * Math.sin(a + 0.45)); ctx.fill();
}
function polyline(v, pts, color, width, close) {
  if (!pts || pts.length < 2) return;
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.beginPath();
  pts.forEach((p, i) => { const [x, y] = toCanvas(v, p[0], p[1]); i ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
  if (close) ctx.closePath();
  ctx.stroke();
}

function waypoint(v, p, n, color) {  // a queued waypoint: its arrow and its number
  arrow(v, p, color, 0.4);
  const [x, y] = toCanvas(v, p.x, p.y);
  ctx.fillStyle = color; ctx.font = "bold 13px system-ui"; ctx.fillText(String(n), x + 6, y + 14);
}

function draw() {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  if (canvas.width !== Math.round(r.width * dpr) || canvas.height !== Math.round(r.height * dpr)) {
    canvas.width = Math.round(r.width * dpr); canvas.height = Math.round(r.height * dpr);
  }
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.fillStyle = "#0d1011"; ctx.fillRect(0, 0, r.width, r.height);
  const v = view(), st = Z.state;
  if (!v) {
    ctx.fillStyle = "#7d8c92"; ctx.fillText("waiting for the map…", 12, 20);
    return;
  }
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(Z.mapImage, v.ox, v.oy, Z.map.width * Z.map.resolution * v.s, Z.map.height * Z.map.resolution * v.s);
  if (st) {
    ctx.fillStyle = "rgba(255,60,60,0.8)";
    for (const p of st.particles) { const [x, y] = toCanvas(v, p[0], p[1]); ctx.fillRect(x - 1, y - 1, 2, 2); }
    if (st.ellipse) {
      const e = st.ellipse, [x, y] = toCanvas(v, e.x, e.y);
      ctx.strokeStyle = "#ff8c00"; ctx.lineWidth = 2; ctx.beginPath();
      ctx.ellipse(x, y, Math.max(e.a * v.s, 1), Math.max(e.b * v.s, 1), -e.angle, 0, 2 * Math.PI); ctx.stroke();
    }
    polyline(v, st.plan, "#28c828", 2, false);
    polyline(v, st.footprint, "#3c78ff", 2, true);
    const m = st.mission;
    if (m && m.active) m.waypoints.forEach((p, i) => waypoint(v, { x: p[0], y: p[1], yaw: p[2] }, i + 1, "#c8a000"));
    if (st.goal) arrow(v, st.goal, "#ff00c8", 0.5);
    if (st.amcl) arrow(v, st.amcl, "#ff8c00", 0.4);
    if (st.pose) arrow(v, st.pose, "#3c78ff", 0.4);
  }
  Z.queue.forEach((p, i) => waypoint(v, p, i + 1, "#ffd84d"));
  if (Z.drag) arrow(v, Z.drag, { goal: "#ff00c8", waypoint: "#ffd84d" }[Z.tool] || "#00e0e0", 0.6);
}

// -- data ----------------------------------------------------------------------------------------
async function loadMap() {
  const r = await fetch("api/map");
  if (!r.ok) return;
  const m = await r.json();
  const grey = Uint8Array.from(atob(m.data), (c) => c.charCodeAt(0));
  const img = new ImageData(m.width, m.height);
  for (let k = 0; k < grey.length; k++) {  // rows come top first (row 0 = highest y): image order
    const g = grey[k];
    img.data[4 * k] = img.data[4 * k + 1] = img.data[4 * k + 2] = g; img.data[4 * k + 3] = 255;
  }
  const off = document.createElement("canvas");
  off.width = m.width; off.height = m.height;
  off.getContext("2d").putImageData(img, 0, 0);
  Z.map = m; Z.mapImage = off;
}

// the link to the monitor, said as it is: live, no data from the robot (stopped?), or reconnecting
Z.link = { ok: null, since: Date.now(), error: "" };
function showLink(ok, st, error) {
  if (ok !== Z.link.ok) Z.link = { ok, since: Date.now(), error: "" };
  if (error) Z.link.error = error;
  const el = document.getElementById("link");
  const where = `monitor ${location.host}`;
  const secs = Math.round((Date.now() - Z.link.since) / 1000);
  if (!ok) {
    el.textContent = `● reconnecting to the ${where} (${secs} s: ${Z.link.error})`;
    el.className = "link down";
  } else if (st.data_age_s === null || st.data_age_s > 3) {
    el.textContent = st.data_age_s === null ? `● ${where}: no data from robot '${st.robot}' yet`
      : `● ${where}: robot '${st.robot}' silent for ${Math.round(st.data_age_s)} s (stopped?)`;
    el.className = "link quiet";
  } else {
    el.textContent = `● live: robot '${st.robot}' via ${where}`;
    el.className = "link live";
  }
}

async function poll() {
  let st;
  try {
    const r = await fetch("api/state", { signal: AbortSignal.timeout(5000) });
    if (!r.ok) throw new Error(`HTTP ${r.status}`);
    st = await r.json();
  } catch (e) {  // the monitor is down or busy: say so, try again
    showLink(false, null, e.name === "TimeoutError" ? "no answer in 5 s" : e.message);
    setTimeout(poll, 1000);
    return;
  }
  showLink(true, st);
  try {  // a drawing error is ours, not the link's: said apart, and the polling goes on
    if (!Z.map || st.map_version !== Z.map.version) await loadMap();
    Z.state = st;
    const mb = st.move_base;
    document.getElementById("robot").textContent = `zenav · ${st.robot}`;
    document.getElementById("mb-state").textContent =
      mb ? `move_base: ${mb.state || "-"} [${mb.status}]` + (mb.goal_id ? ` ${mb.distance.toFixed(2)} m to go` : "")
         : "move_base: not seen";
    document.getElementById("why").textContent = st.why ? `why not moving: ${st.why}` : "";
    const line = st.mission ? st.mission.line : "";
    document.getElementById("mission-state").textContent = !line || line.startsWith("mission") ? line : `mission: ${line}`;
    draw();
  } catch (e) {
    console.error(e);
    note(`page error: ${e.message}`);
  }
  setTimeout(poll, 200);
}

// -- tools ---------------------------------------------------------------------------------------
function setTool(t) {
  Z.tool = Z.tool === t ? null : t;
  for (const b of document.querySelectorAll(".tool")) b.classList.toggle("active", b.id === `tool-${Z.tool}`);
  canvas.classList.toggle("armed", !!Z.tool);
}
document.getElementById("tool-goal").onclick = () => setTool("goal");
document.getElementById("tool-initialpose").onclick = () => setTool("initialpose");
// the waypoint queue: the tool adds waypoints (it stays selected), Go sends them as one mission
document.getElementById("tool-waypoint").onclick = () => setTool("waypoint");
function showQueue() {
  document.getElementById("mission-go").textContent = `Go (${Z.queue.length})`;
  document.getElementById("mission-loop").classList.toggle("active", Z.loop);
  draw();
}
document.getElementById("mission-loop").onclick = () => { Z.loop = !Z.loop; showQueue(); };
document.getElementById("mission-clear").onclick = () => { Z.queue = []; showQueue(); };
document.getElementById("mission-go").onclick = async () => {
  if (!Z.queue.length) { note("no waypoint queued: select Waypoints, then click points of the map"); return; }
  try {
    const out = await post("api/mission", { waypoints: Z.queue, loop: Z.loop });
    note(out.answer);
    Z.queue = []; setTool(null);
  } catch (e) {
    note(`mission refused: ${e.message}`);
  }
  showQueue();
};
document.getElementById("cancel").onclick = () =>
  post("api/cancel").then((out) => note(out.answer)).catch((e) => note(`cancel failed: ${e.message}`));

canvas.addEventListener("mousedown", (ev) => {
  const v = view();
  if (!v) return;
  if (!Z.tool) {  // no tool: drag the map (the view stops following)
    Z.pan = { x: ev.clientX, y: ev.clientY, cx: v.cx, cy: v.cy, s: v.s };
    return;
  }
  const w = Z.clientToWorld(ev.clientX, ev.clientY);
  Z.frozen = v;
  Z.drag = { x: w[0], y: w[1], yaw: 0, moved: false };
  draw();
});
canvas.addEventListener("mousemove", (ev) => {
  if (Z.pan) {
    const p = Z.pan;
    if (Z.follow && Math.hypot(ev.clientX - p.x, ev.clientY - p.y) > 4) setFollow(false);
    if (!Z.follow) Z.centre = [p.cx - (ev.clientX - p.x) / p.s, p.cy + (ev.clientY - p.y) / p.s];
    draw();
    return;
  }
  if (!Z.drag) return;
  const w = Z.clientToWorld(ev.clientX, ev.clientY);
  const dx = w[0] - Z.drag.x, dy = w[1] - Z.drag.y;
  if (Math.hypot(dx, dy) * view().s > 4) { Z.drag.yaw = Math.atan2(dy, dx); Z.drag.moved = true; }
  draw();
});
canvas.addEventListener("wheel", (ev) => { ev.preventDefault(); zoom(ev.deltaY < 0 ? 1.25 : 0.8); }, { passive: false });
window.addEventListener("mouseup", async () => {
  Z.pan = null;
  const d = Z.drag, tool = Z.tool;
  if (!d) return;
  Z.drag = null; Z.frozen = null;
  if (tool === "waypoint") {  // queued here; sent with Go
    Z.queue.push({ x: d.x, y: d.y, yaw: d.yaw });
    note(`waypoint ${Z.queue.length} queued (${d.x.toFixed(2)}, ${d.y.toFixed(2)}); Go sends the queue`);
    showQueue();
    return;
  }
  setTool(null);
  try {
    const out = await post(`api/${tool}`, { x: d.x, y: d.y, yaw: d.yaw });
    Z.sent.push({ tool, x: out.x, y: out.y, yaw: out.yaw });
    note(`${tool === "goal" ? "goal" : "initial pose"} (${d.x.toFixed(2)}, ${d.y.toFixed(2)}, ` +
         `${(d.yaw * 180 / Math.PI).toFixed(0)}°): ${out.answer}`);
  } catch (e) {
    note(`${tool} refused: ${e.message}`);
  }
  draw();
});
document.getElementById("follow").onclick = () => setFollow(!Z.follow);
document.getElementById("zoom-in").onclick = () => zoom(1.25);
document.getElementById("zoom-out").onclick = () => zoom(0.8);
window.addEventListener("resize", draw);

// -- the Rerun viewer (the wheel's own wasm build, served under /rerun/) ------------------------
async function startRerun(cfg) {
  const status = document.getElementById("rerun-status");
  try {
    await wasm_bindgen({ module_or_path: "rerun/re_viewer_bg.wasm" });
    const host = location.hostname.includes(":") ? `[${location.hostname}]` : location.hostname;
    const options = {
      url: [`rerun+http://${host}:${cfg.grpc_port}/proxy`], hide_welcome_screen: true,
      enable_history: false, persist: false, notebook: false, memory_limit: cfg.memory_limit, theme: "dark",
      on_viewer_event: (ev) => { Z.viewerEvents = Z.viewerEvents.concat([ev]).slice(-20); },
    };
    let handle;
    try { handle = new wasm_bindgen.WebHandle(options); } catch (e) {
      delete options.memory_limit;  // an older option format: start without it
      handle = new wasm_bindgen.WebHandle(options);
    }
    await handle.start(document.getElementById("rerun_canvas"));
    Z.handle = handle; Z.rerun = "started";
    status.remove();
  } catch (e) {
    Z.rerun = `failed: ${e}`;
    status.textContent = `the Rerun viewer could not start: ${e}`;
  }
}

// ?viewer=0: the map panel and its tools alone (the viewer's wasm is heavy for a weak machine)
const withViewer = new URLSearchParams(location.search).get("viewer") !== "0";
if (!withViewer) {
  document.getElementById("rerun-panel").remove();
  document.getElementById("map-panel").style.flex = "1 1 auto";
  Z.rerun = "off";
}
fetch("api/config").then((r) => r.json()).then((cfg) => {
  Z.config = cfg;
  poll();
  if (withViewer) startRerun(cfg);
});
