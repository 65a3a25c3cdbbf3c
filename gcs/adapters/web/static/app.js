// gcs live map: draws /api/world once, then every snapshot of /events (Server-Sent Events).
// Coordinates are ENU metres; SVG's y grows downwards, so every point is drawn at (x, -y).
// Testable state is in the DOM: <body data-snapshots data-connected data-mode>, and every
// vehicle / track / truth element carries data-x and data-y in ENU metres (a track also
// data-target, its id, which its label shows; a sight line data-track, the track it goes to).
"use strict";

const COLOURS = ["#1e88e5", "#43a047", "#8e24aa", "#f4511e", "#00acc1", "#6d4c41", "#3949ab", "#c0ca33"];
const svg = document.getElementById("map");
const layers = {};
for (const name of ["world", "truth", "plans", "trails", "track", "vehicles"]) {
  layers[name] = document.getElementById("layer-" + name);
}
const state = { world: null, tracks: null, view: null, snapshots: 0 };

function esc(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
}
function pts(list) {
  return list.map((p) => p[0] + "," + -p[1]).join(" ");
}
function colour(index) {
  return COLOURS[index % COLOURS.length];
}
function metresPerPixel() {
  const box = svg.getBoundingClientRect();
  return state.view ? Math.max(state.view.w / Math.max(box.width, 1), state.view.h / Math.max(box.height, 1)) : 1;
}
function fmt(value, digits) {
  return value === null || value === undefined ? "-" : Number(value).toFixed(digits);
}

// ---------------------------------------------------------------- view box: fit, zoom, pan

function setView(view) {
  state.view = view;
  svg.setAttribute("viewBox", `${view.x} ${view.y} ${view.w} ${view.h}`);
  render();
}
function fit() {
  if (!state.world) return;
  const [w, h] = state.world.size_m;
  let xmin = 0, ymin = 0, xmax = w, ymax = h;
  for (const v of state.world.vehicles) {
    xmin = Math.min(xmin, v.start[0]); xmax = Math.max(xmax, v.start[0]);
    ymin = Math.min(ymin, v.start[1]); ymax = Math.max(ymax, v.start[1]);
  }
  const margin = 0.04 * Math.max(xmax - xmin, ymax - ymin, 1);
  setView({ x: xmin - margin, y: -ymax - margin, w: xmax - xmin + 2 * margin, h: ymax - ymin + 2 * margin });
}
function svgPoint(event) {
  const box = svg.getBoundingClientRect();
  const scale = metresPerPixel();
  const cx = state.view.x + state.view.w / 2, cy = state.view.y + state.view.h / 2;
  return [cx + (event.clientX - box.left - box.width / 2) * scale, cy + (event.clientY - box.top - box.height / 2) * scale];
}
svg.addEventListener("wheel", (event) => {
  if (!state.view) return;
  event.preventDefault();
  const factor = Math.exp(event.deltaY * 0.0015);
  const [px, py] = svgPoint(event);
  const v = state.view;
  setView({ x: px - (px - v.x) * factor, y: py - (py - v.y) * factor, w: v.w * factor, h: v.h * factor });
}, { passive: false });
let drag = null;
svg.addEventListener("mousedown", (event) => {
  drag = { x: event.clientX, y: event.clientY, view: { ...state.view } };
  svg.classList.add("dragging");
});
window.addEventListener("mousemove", (event) => {
  if (!drag) return;
  const scale = metresPerPixel();
  setView({ ...drag.view, x: drag.view.x - (event.clientX - drag.x) * scale, y: drag.view.y - (event.clientY - drag.y) * scale });
});
window.addEventListener("mouseup", () => { drag = null; svg.classList.remove("dragging"); });
svg.addEventListener("dblclick", fit);
document.getElementById("fit").addEventListener("click", fit);
window.addEventListener("resize", render);

// ---------------------------------------------------------------------------- drawing

function drawWorld(world) {
  const [w, h] = world.size_m;
  const top = Math.max(1, ...world.buildings.map((b) => b.height_m));
  const parts = [`<rect class="city" x="0" y="${-h}" width="${w}" height="${h}"/>`];
  for (const b of world.buildings) {
    const shade = Math.round(200 - 90 * (b.height_m / top));
    parts.push(`<polygon class="building" points="${pts(b.footprint)}" fill="rgb(${shade},${shade - 4},${shade - 12})"><title>${fmt(b.height_m, 0)} m</title></polygon>`);
  }
  for (const zone of world.no_fly) {
    parts.push(`<polygon class="nofly" data-name="${esc(zone.name)}" points="${pts(zone.polygon)}"><title>no-fly ${esc(zone.name)}: ${fmt(zone.floor_m, 0)}-${fmt(zone.ceiling_m, 0)} m</title></polygon>`);
  }
  layers.world.innerHTML = parts.join("");
  layers.world.dataset.buildings = String(world.buildings.length);
  layers.world.dataset.noFly = String(world.no_fly.length);
}

function ellipse(cls, x, y, e, extra) {
  const deg = (-e.angle_rad * 180) / Math.PI;
  return `<ellipse class="${cls}" cx="${x}" cy="${-y}" rx="${Math.max(e.rx, 0.1)}" ry="${Math.max(e.ry, 0.1)}" transform="rotate(${deg} ${x} ${-y})" ${extra || ""}/>`;
}

function render() {
  const tracks = state.tracks;
  if (!tracks || !state.view) return;
  const unit = metresPerPixel();
  const order = new Map((state.world ? state.world.vehicles : []).map((v, i) => [v.id, i]));
  const colourOf = (id, i) => colour(order.has(id) ? order.get(id) : i);

  const truth = [];
  for (const t of tracks.truth) {
    const s = 6 * unit;
    truth.push(`<polyline class="truth-trail" points="${pts(t.trail)}"/>`);
    truth.push(`<g id="truth-${esc(t.target_id)}" class="truth" data-x="${t.x}" data-y="${t.y}" data-stamp="${t.stamp_ns}">` +
      `<path class="truth-mark" d="M${t.x - s},${-t.y - s}L${t.x + s},${-t.y + s}M${t.x - s},${-t.y + s}L${t.x + s},${-t.y - s}"/></g>`);
  }
  layers.truth.innerHTML = truth.join("");

  const plans = [], trails = [], vehicles = [];
  tracks.vehicles.forEach((v, i) => {
    const c = colourOf(v.id, i);
    if (v.plan.length) plans.push(`<polyline id="plan-${esc(v.id)}" class="plan" stroke="${c}" data-points="${v.plan.length}" points="${pts(v.plan)}"/>`);
    if (v.trail.length) trails.push(`<polyline id="trail-${esc(v.id)}" class="trail" stroke="${c}" data-points="${v.trail.length}" points="${pts(v.trail)}"/>`);
    if (v.x === null) return;
    const deg = v.heading_rad === null ? 0 : (-v.heading_rad * 180) / Math.PI;
    const s = 9 * unit;
    const sight = v.detected ? sightTargets(v, tracks.tracks).map((t) =>
      `<line class="sight" data-track="${esc(t.target_id)}" x1="${v.x}" y1="${-v.y}" x2="${t.x}" y2="${-t.y}"/>`).join("") : "";
    vehicles.push(`<g id="vehicle-${esc(v.id)}" class="vehicle link-${esc(v.link)}" data-x="${v.x}" data-y="${v.y}" ` +
      `data-heading="${v.heading_rad}" data-link="${esc(v.link)}" data-detected="${v.detected}" data-stamp="${v.stamp_ns}">${sight}` +
      `<path class="vehicle-body" fill="${c}" transform="translate(${v.x} ${-v.y}) rotate(${deg})" d="M${1.4 * s},0L${-s},${0.8 * s}L${-0.5 * s},0L${-s},${-0.8 * s}Z"/>` +
      `<text x="${v.x + 1.5 * s}" y="${-v.y - 1.5 * s}" font-size="${12 * unit}">${esc(v.id)}</text></g>`);
  });
  layers.plans.innerHTML = plans.join("");
  layers.trails.innerHTML = trails.join("");
  layers.vehicles.innerHTML = vehicles.join("");

  const paths = [], marks = [];  // every trail and prediction under every track's ellipse, dot and label
  const labels = labelPlaces(tracks.tracks, unit);
  tracks.tracks.forEach((t, i) => {
    const id = esc(t.target_id);
    paths.push(`<polyline class="track-trail" points="${pts(t.trail)}"/>`);
    if (t.prediction.length) {
      paths.push(`<polyline id="prediction-${id}" class="prediction" data-points="${t.prediction.length}" points="${pts([[t.x, t.y], ...t.prediction.map((p) => [p.x, p.y])])}"/>`);
      for (const p of t.prediction) paths.push(ellipse("prediction-ellipse", p.x, p.y, p.ellipse));
    }
    marks.push(`<g id="track-${id}" class="track" data-target="${id}" data-x="${t.x}" data-y="${t.y}" data-seq="${t.seq}" ` +
      `data-stamp="${t.stamp_ns}" data-rx="${t.ellipse.rx}" data-ry="${t.ellipse.ry}">` + ellipse("track-ellipse", t.x, t.y, t.ellipse) +
      `<circle class="track-dot" cx="${t.x}" cy="${-t.y}" r="${4 * unit}"/>` +
      `<text class="track-label" x="${labels[i][0]}" y="${labels[i][1]}" font-size="${12 * unit}">${id}</text></g>`);
  });
  layers.track.innerHTML = paths.join("") + marks.join("");
  drawScaleBar(unit);
}

// Where each track's label goes (SVG coordinates): right of its dot, moved down a line while it
// would overlap a label placed before it (two cars side by side are a few metres apart, a pixel
// or two on the map).
function labelPlaces(tracks, unit) {
  const line = 13 * unit, placed = [];
  return tracks.map((t) => {
    const x = t.x + 7 * unit, w = (7 * String(t.target_id).length + 3) * unit;
    let y = -t.y + 4 * unit;
    while (placed.some((p) => x < p.x + p.w && p.x < x + w && Math.abs(p.y - y) < line)) y += line;
    placed.push({ x, y, w });
    return [x, y];
  });
}

// The tracks a detecting vehicle's sight lines go to: those its reports went into (their
// `contributing`), else the nearest one.
function sightTargets(vehicle, tracks) {
  // The tracks the vehicle's detections went into; none when they went into none (clutter, or a report late).
  return tracks.filter((t) => t.contributing.includes(vehicle.id));
}

function drawScaleBar(unit) {
  const v = state.view;
  const want = 120 * unit;
  const step = Math.pow(10, Math.floor(Math.log10(want)));
  const length = [5, 2, 1].map((m) => m * step).find((l) => l <= want) || step;
  const x = v.x + 20 * unit, y = v.y + v.h - 20 * unit;
  document.getElementById("scale-bar").innerHTML =
    `<line class="scale-bar" x1="${x}" y1="${y}" x2="${x + length}" y2="${y}"/>` +
    `<text x="${x}" y="${y - 6 * unit}" font-size="${12 * unit}">${length >= 1000 ? length / 1000 + " km" : length + " m"}</text>`;
}

// ------------------------------------------------------------------------------ panel

function renderStatus(status, truths) {
  document.body.dataset.mode = status.mode;
  document.getElementById("scenario").textContent = `${status.scenario} (${status.mode})`;
  const t = status.stamp_ns === null ? null : (status.stamp_ns - status.first_stamp_ns) / 1e9;
  document.getElementById("clock").textContent = `t = ${fmt(t, 1)} s` + (status.uptime_s !== null ? `, up ${fmt(status.uptime_s, 0)} s` : "");
  document.querySelector("#status-vehicles tbody").innerHTML = status.vehicles.map((v) =>
    `<tr data-id="${esc(v.id)}" data-link="${esc(v.link)}"><td>${esc(v.id)}</td><td><span class="link-dot link-${esc(v.link)}"></span>${esc(v.link)}</td>` +
    `<td>${v.reports}</td><td>${v.detected === null ? "-" : v.detected ? "yes" : "no"}</td><td>${esc(v.autopilot || "-")}</td></tr>`).join("");
  const rmse = document.getElementById("rmse");
  const errors = Object.values(status.errors);
  rmse.textContent = errors.length
    ? errors.map((e) => `${fmt(e.rmse_m, 1)} m over ${e.scored} steps (last ${fmt(e.last_error_m, 1)} m)`).join("; ")
    : truths ? "- (no track scored against a truth)" : "- (no truth)";
  rmse.dataset.rmse = status.rmse_m === null ? "" : String(status.rmse_m);
  document.querySelector("#counters tbody").innerHTML = Object.keys(status.counters).sort().map((k) =>
    `<tr><td>${esc(k)}</td><td>${status.counters[k]}</td></tr>`).join("");
  const controls = document.getElementById("replay-controls");
  controls.hidden = !status.replay;
  if (status.replay) {
    const r = status.replay;
    document.getElementById("play").textContent = r.playing ? "pause" : "play";
    const speed = document.getElementById("speed");
    if (document.activeElement !== speed) speed.value = String(r.speed);
    document.getElementById("replay-position").textContent =
      `${fmt(r.position_s, 1)} / ${r.duration_s === null ? "?" : fmt(r.duration_s, 1)} s${r.ended ? " (end)" : ""}`;
  }
}

// One row a track: id, position, speed, 2-sigma semi-axes, the vehicles whose reports went into it.
function renderTrackSummary(tracks) {
  const rows = tracks.tracks.map((t) =>
    `<tr data-target="${esc(t.target_id)}" data-seq="${t.seq}"><td>${esc(t.target_id)}</td>` +
    `<td>(${fmt(t.x, 0)}, ${fmt(t.y, 0)})</td><td>${fmt(Math.hypot(t.vx || 0, t.vy || 0), 1)}</td>` +
    `<td>${fmt(t.ellipse.rx, 1)} x ${fmt(t.ellipse.ry, 1)}</td><td>${esc(t.contributing.join(", ") || "predicted")}</td></tr>`);
  document.querySelector("#track-list tbody").innerHTML = rows.length ? rows.join("") : `<tr class="none"><td colspan="5">none yet</td></tr>`;
  document.getElementById("track-count").textContent = String(tracks.tracks.length);
}

// ------------------------------------------------------------------------- data flow

function onSnapshot(snapshot) {
  if (!snapshot.tracks || !snapshot.status) return;
  state.tracks = snapshot.tracks;
  state.snapshots += 1;
  renderStatus(snapshot.status, snapshot.tracks.truth.length);
  renderTrackSummary(snapshot.tracks);
  render();
  document.body.dataset.snapshots = String(state.snapshots);
}

function connect() {
  const events = new EventSource("events");
  const connection = document.getElementById("connection");
  events.onopen = () => {
    connection.textContent = "connected";
    connection.className = "ok";
    document.body.dataset.connected = "true";
  };
  events.onerror = () => {
    connection.textContent = "reconnecting";
    connection.className = "bad";
    document.body.dataset.connected = "false";
  };
  events.addEventListener("snapshot", (event) => onSnapshot(JSON.parse(event.data)));
}

function control(body) {
  fetch("api/replay", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) })
    .then((r) => r.json()).then((answer) => { if (answer.error) console.warn(answer.error); });
}
document.getElementById("play").addEventListener("click", (e) => control({ action: e.target.textContent === "pause" ? "pause" : "play" }));
document.getElementById("restart").addEventListener("click", () => control({ action: "restart" }));
document.getElementById("speed").addEventListener("change", (e) => control({ speed: Number(e.target.value) }));

fetch("api/world").then((r) => r.json()).then((world) => {
  state.world = world;
  drawWorld(world);
  fit();
  connect();
});
