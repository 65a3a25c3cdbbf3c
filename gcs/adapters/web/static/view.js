// gcs live map: the view box (which part of the city is on screen).
// Coordinates are ENU metres; SVG's y grows downwards, so every point is drawn at (x, -y) and the view box is
// in those SVG coordinates. Three ways to look (<body data-view>):
//   follow  (the default) frames the vehicles and targets, and frames them again, gliding there, when one comes
//           within FOLLOW_EDGE of the screen's edge or when they fill less than FOLLOW_SHRINK of it;
//   city    the whole city;
//   free    after a wheel zoom or a drag, until "follow" or "whole city" is pressed.
// While the view glides, <svg data-moving="true">.
"use strict";

const svg = document.getElementById("map");
const state = { world: null, tracks: null, view: null, snapshots: 0, look: "follow", trailS: 60 };

const FOLLOW_MIN_SPAN_M = 800;  // the followed frame is at least this wide and high
const FOLLOW_PAD = 0.2;        // margin about what is followed, a fraction of its span...
const FOLLOW_PAD_MIN_M = 100;  // ...and at least this
const FOLLOW_EDGE = 0.08;      // reframe when something followed is this close to the edge (fraction of the screen)
const FOLLOW_SHRINK = 0.4;     // reframe when what is followed (with its margin) spans less than this of the screen
const GLIDE_MS = 400;

function metresPerPixel() {
  const box = svg.getBoundingClientRect();
  return state.view ? Math.max(state.view.w / Math.max(box.width, 1), state.view.h / Math.max(box.height, 1)) : 1;
}

// The part of the plane on screen: the view box widened to the screen's shape (preserveAspectRatio meet).
function visibleBox() {
  const box = svg.getBoundingClientRect(), unit = metresPerPixel(), v = state.view;
  const w = box.width * unit, h = box.height * unit;
  return { x: v.x + v.w / 2 - w / 2, y: v.y + v.h / 2 - h / 2, w, h };
}

function setView(view) {
  state.view = view;
  svg.setAttribute("viewBox", `${view.x} ${view.y} ${view.w} ${view.h}`);
  render();
}

let glide = null;
function glideTo(view) {
  if (!state.view) { setView(view); return; }
  glide = { from: { ...state.view }, to: view, start: performance.now() };
  svg.dataset.moving = "true";
  requestAnimationFrame(glideStep);
}
function glideStep(now) {
  if (!glide) return;
  const f = Math.min(1, (now - glide.start) / GLIDE_MS), e = f * f * (3 - 2 * f);
  const mix = (k) => glide.from[k] + (glide.to[k] - glide.from[k]) * e;
  setView({ x: mix("x"), y: mix("y"), w: mix("w"), h: mix("h") });
  if (f < 1) { requestAnimationFrame(glideStep); return; }
  glide = null;
  svg.dataset.moving = "false";
}
function stopGlide() {
  glide = null;
  svg.dataset.moving = "false";
}

function setLook(look) {
  state.look = look;
  document.body.dataset.view = look;
  document.getElementById("follow").setAttribute("aria-pressed", String(look === "follow"));
  document.getElementById("city").setAttribute("aria-pressed", String(look === "city"));
}

function showCity() {
  if (!state.world) return;
  stopGlide();
  setLook("city");
  const [x0, y0, x1, y1] = worldBounds(state.world);
  const w = x1 - x0, h = y1 - y0, margin = 0.04 * Math.max(w, h, 1);
  setView({ x: x0 - margin, y: -y1 - margin, w: w + 2 * margin, h: h + 2 * margin });
}

// What follow keeps in view (SVG coordinates): every placed vehicle, track and truth; before the first snapshot,
// the vehicles' start points.
function followedPoints() {
  const points = [];
  if (state.tracks) {
    for (const v of state.tracks.vehicles) if (v.x !== null) points.push([v.x, -v.y]);
    for (const t of state.tracks.tracks) points.push([t.x, -t.y]);
    for (const t of state.tracks.truth) points.push([t.x, -t.y]);
  }
  if (!points.length && state.world) for (const v of state.world.vehicles) points.push([v.start[0], -v.start[1]]);
  return points;
}

function frameOf(points) {
  const xs = points.map((p) => p[0]), ys = points.map((p) => p[1]);
  const xmin = Math.min(...xs), xmax = Math.max(...xs), ymin = Math.min(...ys), ymax = Math.max(...ys);
  const pad = Math.max(FOLLOW_PAD * Math.max(xmax - xmin, ymax - ymin), FOLLOW_PAD_MIN_M);
  const w = Math.max(xmax - xmin + 2 * pad, FOLLOW_MIN_SPAN_M), h = Math.max(ymax - ymin + 2 * pad, FOLLOW_MIN_SPAN_M);
  return { x: (xmin + xmax) / 2 - w / 2, y: (ymin + ymax) / 2 - h / 2, w, h };
}

// Whether the followed points need a new frame: one near the screen's edge, or all of them small in it.
function needsFrame(points, frame) {
  if (!state.view) return true;
  const vis = visibleBox(), edge = FOLLOW_EDGE * Math.min(vis.w, vis.h);
  const outside = points.some(([x, y]) => x < vis.x + edge || x > vis.x + vis.w - edge || y < vis.y + edge || y > vis.y + vis.h - edge);
  return outside || (frame.w < FOLLOW_SHRINK * vis.w && frame.h < FOLLOW_SHRINK * vis.h);
}

function follow(force) {
  const points = followedPoints();
  if (!points.length || (glide && !force)) return;  // a glide under way ends before the next look
  const frame = frameOf(points);
  if (force || needsFrame(points, frame)) glideTo(frame);
}

function startFollowing() {
  setLook("follow");
  follow(true);
}

function svgPoint(event) {
  const box = svg.getBoundingClientRect(), vis = visibleBox(), unit = metresPerPixel();
  return [vis.x + (event.clientX - box.left) * unit, vis.y + (event.clientY - box.top) * unit];
}
svg.addEventListener("wheel", (event) => {
  if (!state.view) return;
  event.preventDefault();
  stopGlide();
  setLook("free");
  const factor = Math.exp(event.deltaY * 0.0015);
  const [px, py] = svgPoint(event);
  const v = state.view;
  setView({ x: px - (px - v.x) * factor, y: py - (py - v.y) * factor, w: v.w * factor, h: v.h * factor });
}, { passive: false });
let drag = null;
svg.addEventListener("mousedown", (event) => {
  drag = { x: event.clientX, y: event.clientY, view: { ...state.view }, moved: false };
  svg.classList.add("dragging");
});
window.addEventListener("mousemove", (event) => {
  if (!drag) return;
  if (!drag.moved && Math.hypot(event.clientX - drag.x, event.clientY - drag.y) < 4) return;  // a click, not a drag
  drag.moved = true;
  stopGlide();
  setLook("free");
  const scale = metresPerPixel();
  setView({ ...drag.view, x: drag.view.x - (event.clientX - drag.x) * scale, y: drag.view.y - (event.clientY - drag.y) * scale });
});
window.addEventListener("mouseup", () => { drag = null; svg.classList.remove("dragging"); });
svg.addEventListener("dblclick", startFollowing);
document.getElementById("follow").addEventListener("click", startFollowing);
document.getElementById("city").addEventListener("click", showCity);
window.addEventListener("resize", () => (state.look === "follow" ? follow(true) : render()));
