// zenav monitor page: the map panel's view, world (ROS map frame: x right, y up) <-> panel pixels.
//
// By default the view follows the robot: it is centred on the robot at a scale that shows about
// FOLLOW_SPAN_M metres across the panel's shorter side, or the whole map when that is smaller (then
// following changes nothing). The centre is clamped so the map's edges stay outside the panel where the
// map is larger than it (no empty margin next to a wall). "Fix view" (or dragging the map without a tool)
// keeps the current centre; zoom multiplies the default scale.
"use strict";

const ZenavView = (() => {
  const FOLLOW_SPAN_M = 12;
  const ZOOM_MIN = 0.1, ZOOM_MAX = 20;
  const clamp = (v, lo, hi) => Math.min(Math.max(v, lo), hi);

  // rect: {width, height} of the panel (CSS px); map: /api/map's geometry; opt: {zoom, follow, pose, centre}
  function make(rect, map, opt) {
    const w = map.width * map.resolution, h = map.height * map.resolution;
    const x0 = map.origin.x, y0 = map.origin.y;
    const fit = Math.min(rect.width / w, rect.height / h) * 0.98;
    const base = Math.max(fit, Math.min(rect.width, rect.height) / FOLLOW_SPAN_M);
    const s = clamp(base * (opt.zoom || 1), Math.min(fit, base), base * ZOOM_MAX);
    const following = !!(opt.follow && opt.pose);
    let [cx, cy] = following ? [opt.pose.x, opt.pose.y] : (opt.centre || [x0 + w / 2, y0 + h / 2]);
    const hx = rect.width / (2 * s), hy = rect.height / (2 * s);
    cx = w <= 2 * hx ? x0 + w / 2 : clamp(cx, x0 + hx, x0 + w - hx);
    cy = h <= 2 * hy ? y0 + h / 2 : clamp(cy, y0 + hy, y0 + h - hy);
    return {
      s, cx, cy, following, whole: w <= 2 * hx && h <= 2 * hy,
      // canvas position of the map's top-left corner (x0, y0 + h): where its image is drawn
      ox: rect.width / 2 - (cx - x0) * s, oy: rect.height / 2 - (y0 + h - cy) * s, x0, y1: y0 + h,
    };
  }
  const toCanvas = (v, x, y) => [v.ox + (x - v.x0) * v.s, v.oy + (v.y1 - y) * v.s];
  const toWorld = (v, px, py) => [v.x0 + (px - v.ox) / v.s, v.y1 - (py - v.oy) / v.s];
  const zoomBy = (zoom, factor) => clamp(zoom * factor, ZOOM_MIN, ZOOM_MAX);
  return { make, toCanvas, toWorld, zoomBy, FOLLOW_SPAN_M };
})();
