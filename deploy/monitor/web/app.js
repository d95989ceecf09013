// zenav monitor page: the Rerun web viewer (right) and a top-down map panel with rviz's tools (left).
// The map panel is drawn from /api/map and /api/state; clicks become POSTs to /api/goal, /api/initialpose.
"use strict";

const Z = (window.zenav = {
  tool: null, map: null, mapImage: null, state: null, config: null, drag: null,
  viewerEvents: [], rerun: "starting", sent: [],
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

// -- view: the whole map fitted into the panel (x right, y up) ------------------------------------
function view() {
  const r = canvas.getBoundingClientRect();
  const m = Z.map;
  if (!m) return null;
  const w = m.width * m.resolution, h = m.height * m.resolution;
  const s = Math.min(r.width / w, r.height / h) * 0.98;
  const ox = (r.width - w * s) / 2, oy = (r.height - h * s) / 2;
  return { s, ox, oy, x0: m.origin.x, y1: m.origin.y + h, rect: r };
}
function toCanvas(v, x, y) { return [v.ox + (x - v.x0) * v.s, v.oy + (v.y1 - y) * v.s]; }
function toWorld(v, cx, cy) { return [v.x0 + (cx - v.ox) / v.s, v.y1 - (cy - v.oy) / v.s]; }
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
    if (st.goal) arrow(v, st.goal, "#ff00c8", 0.5);
    if (st.amcl) arrow(v, st.amcl, "#ff8c00", 0.4);
    if (st.pose) arrow(v, st.pose, "#3c78ff", 0.4);
  }
  if (Z.drag) arrow(v, Z.drag, Z.tool === "goal" ? "#ff00c8" : "#00e0e0", 0.6);
}

// -- data ----------------------------------------------------------------------------------------
async function loadMap() {
  const r = await fetch("api/map");
  if (!r.ok) return;
  const m = await r.json();
  const grey = Uint8Array.from(atob(m.data), (c) => c.charCodeAt(0));
  const img = new ImageData(m.width, m.height);
  for (let row = 0; row < m.height; row++) {  // row 0 is the lowest y: drawn at the bottom
    const src = row * m.width, dst = (m.height - 1 - row) * m.width;
    for (let c = 0; c < m.width; c++) {
      const g = grey[src + c], k = 4 * (dst + c);
      img.data[k] = img.data[k + 1] = img.data[k + 2] = g; img.data[k + 3] = 255;
    }
  }
  const off = document.createElement("canvas");
  off.width = m.width; off.height = m.height;
  off.getContext("2d").putImageData(img, 0, 0);
  Z.map = m; Z.mapImage = off;
}

async function poll() {
  try {
    const st = await (await fetch("api/state")).json();
    if (!Z.map || st.map_version !== Z.map.version) await loadMap();
    Z.state = st;
    const mb = st.move_base;
    document.getElementById("robot").textContent = `zenav · ${st.robot}`;
    document.getElementById("mb-state").textContent =
      mb ? `move_base: ${mb.state || "-"} [${mb.status}]` + (mb.goal_id ? ` ${mb.distance.toFixed(2)} m to go` : "")
         : "move_base: not seen";
    document.getElementById("why").textContent = st.why ? `why not moving: ${st.why}` : "";
    draw();
  } catch (e) {
    document.getElementById("mb-state").textContent = "monitor unreachable";
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
document.getElementById("cancel").onclick = () =>
  post("api/cancel").then(() => note("cancel sent")).catch((e) => note(`cancel failed: ${e.message}`));

canvas.addEventListener("mousedown", (ev) => {
  const w = Z.tool && Z.clientToWorld(ev.clientX, ev.clientY);
  if (!w) return;
  Z.drag = { x: w[0], y: w[1], yaw: 0, moved: false };
  draw();
});
canvas.addEventListener("mousemove", (ev) => {
  if (!Z.drag) return;
  const w = Z.clientToWorld(ev.clientX, ev.clientY);
  const dx = w[0] - Z.drag.x, dy = w[1] - Z.drag.y;
  if (Math.hypot(dx, dy) * view().s > 4) { Z.drag.yaw = Math.atan2(dy, dx); Z.drag.moved = true; }
  draw();
});
window.addEventListener("mouseup", async () => {
  const d = Z.drag, tool = Z.tool;
  if (!d) return;
  Z.drag = null;
  setTool(null);
  try {
    const out = await post(`api/${tool}`, { x: d.x, y: d.y, yaw: d.yaw });
    Z.sent.push({ tool, x: out.x, y: out.y, yaw: out.yaw });
    note(`${tool === "goal" ? "goal" : "initial pose"} (${d.x.toFixed(2)}, ${d.y.toFixed(2)}, ` +
         `${(d.yaw * 180 / Math.PI).toFixed(0)}°) sent`);
  } catch (e) {
    note(`${tool} refused: ${e.message}`);
  }
  draw();
});
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
