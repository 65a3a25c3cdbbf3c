// gcs live map: drawing the city once (its roads: roads.js) and every snapshot on it (a federation's part:
// federation.js).
// Testable state is in the DOM: every vehicle / track / truth element carries data-x and data-y in ENU metres (a
// track also data-target, its id; a sight line data-track, the track it goes to); a label (#layer-labels) carries
// data-for, the id of what it names; a trail band data-age-s, the age of its newest end; the legend's vehicles
// data-id and their swatch's colour.
"use strict";

// Vehicle colours: none of them green (sight lines), magenta (tracks), orange (predictions), red (no-fly) or black
// (truth), so that every colour on the map means one thing, as the legend says.
const VEHICLE_COLOURS = ["#1e88e5", "#5e35b1", "#00838f", "#6d4c41", "#283593", "#546e7a"];
const TRAIL_BANDS = 10;  // a trail is drawn in bands of equal age, each fainter than the newer one
const MARK_PX = { vehicle: 13, track: 5, truth: 7 };  // half the size of each mark on screen
const layers = {};
for (const name of ["world", "federation-areas", "truth", "plans", "trails", "track", "federation", "vehicles", "labels"]) {
  layers[name] = document.getElementById("layer-" + name);
}
const colourIndex = new Map();

function esc(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
}
function pts(list) {
  return list.map((p) => p[0] + "," + -p[1]).join(" ");
}
function fmt(value, digits) {
  return value === null || value === undefined ? "-" : Number(value).toFixed(digits);
}

// A vehicle's colour: by its place in the scenario, then by order of appearance.
function vehicleColour(id) {
  if (!colourIndex.has(id)) colourIndex.set(id, colourIndex.size);
  return VEHICLE_COLOURS[colourIndex.get(id) % VEHICLE_COLOURS.length];
}

// The world's extent [west, south, east, north] in ENU metres: a real city's content with a margin, a generated
// city's rectangle from the origin (a page from a server that sends only size_m: that rectangle).
function worldBounds(world) {
  return world.bounds_m || [0, 0, world.size_m[0], world.size_m[1]];
}

function drawWorld(world) {
  const [x0, y0, x1, y1] = worldBounds(world);
  const top = Math.max(1, ...world.buildings.map((b) => b.height_m));
  const parts = [`<rect class="city" x="${x0}" y="${-y1}" width="${x1 - x0}" height="${y1 - y0}"/>`, roadsMarkup(world)];
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
  showRoads();
  for (const v of world.vehicles) vehicleColour(v.id);
}

// A trail ([x, y, t] oldest first, t its stamp in s from the trails' epoch) as polylines of TRAIL_BANDS ages over the chosen trail time:
// the newest band opaque, each older one a tenth fainter; points older than the trail time are not drawn.
function fadingTrail(cls, points, newestS, attrs) {
  const band = state.trailS / TRAIL_BANDS, out = [];
  let run = [], runBand = null;
  const flush = () => {
    if (run.length > 1) {
      out.push(`<polyline class="${cls}" ${attrs} data-age-s="${fmt(runBand * band, 1)}" ` +
        `stroke-opacity="${fmt(1 - runBand / TRAIL_BANDS, 2)}" points="${pts(run)}"/>`);
    }
  };
  for (const p of points) {
    const age = newestS - p[2];
    if (age > state.trailS) continue;
    const b = Math.min(TRAIL_BANDS - 1, Math.max(0, Math.floor(age / band)));
    if (b !== runBand) {
      const joint = run[run.length - 1];
      flush();
      run = joint ? [joint] : [];
      runBand = b;
    }
    run.push(p);
  }
  flush();
  return out.join("");
}

function ellipse(cls, x, y, e, extra) {
  const deg = (-e.angle_rad * 180) / Math.PI;
  return `<ellipse class="${cls}" cx="${x}" cy="${-y}" rx="${Math.max(e.rx, 0.1)}" ry="${Math.max(e.ry, 0.1)}" transform="rotate(${deg} ${x} ${-y})" ${extra || ""}/>`;
}

function render() {
  drawRoadArrows();
  const tracks = state.tracks;
  if (!tracks || !state.view) return;
  const unit = metresPerPixel(), seconds = (ns) => (ns - tracks.trail_epoch_ns) / 1e9;  // trail time, as the points'
  const newestS = seconds(tracks.stamp_ns);
  const labelItems = [], marks = [];

  const truth = [];
  for (const t of tracks.truth) {
    const s = 6 * unit;
    truth.push(fadingTrail("truth-trail", [...t.trail, [t.x, t.y, seconds(t.stamp_ns)]], newestS, ""));
    truth.push(`<g id="truth-${esc(t.target_id)}" class="truth" data-x="${t.x}" data-y="${t.y}" data-stamp="${t.stamp_ns}">` +
      `<path class="truth-mark" d="M${t.x - s},${-t.y - s}L${t.x + s},${-t.y + s}M${t.x - s},${-t.y + s}L${t.x + s},${-t.y - s}"/></g>`);
    marks.push({ x: t.x, y: -t.y, r: MARK_PX.truth });
  }
  layers.truth.innerHTML = truth.join("");

  const plans = [], trails = [], vehicles = [];
  for (const v of tracks.vehicles) {
    const c = vehicleColour(v.id), id = esc(v.id);
    if (v.plan.length) plans.push(`<polyline id="plan-${id}" class="plan" stroke="${c}" data-points="${v.plan.length}" points="${pts(v.plan)}"/>`);
    const here = v.x === null ? [] : [[v.x, v.y, seconds(v.stamp_ns)]];
    trails.push(`<g id="trail-${id}" class="trail-of" data-points="${v.trail.length}">` +
      fadingTrail("trail", [...v.trail, ...here], newestS, `stroke="${c}"`) + "</g>");
    if (v.x === null) continue;
    const deg = v.heading_rad === null ? 0 : (-v.heading_rad * 180) / Math.PI;
    const s = 9 * unit;
    const sight = v.detected ? sightTargets(v, tracks.tracks).map((t) =>
      `<line class="sight" data-track="${esc(t.target_id)}" x1="${v.x}" y1="${-v.y}" x2="${t.x}" y2="${-t.y}"/>`).join("") : "";
    vehicles.push(`<g id="vehicle-${id}" class="vehicle link-${esc(v.link)}" data-x="${v.x}" data-y="${v.y}" ` +
      `data-heading="${v.heading_rad}" data-link="${esc(v.link)}" data-detected="${v.detected}" data-stamp="${v.stamp_ns}" data-colour="${c}">${sight}` +
      `<path class="vehicle-body" fill="${c}" transform="translate(${v.x} ${-v.y}) rotate(${deg})" d="M${1.4 * s},0L${-s},${0.8 * s}L${-0.5 * s},0L${-s},${-0.8 * s}Z"/></g>`);
    labelItems.push({ key: `vehicle-${id}`, x: v.x, y: -v.y, text: v.id, weight: 400, r: MARK_PX.vehicle, cls: "vehicle-label", fill: c });
    marks.push({ x: v.x, y: -v.y, r: MARK_PX.vehicle });
  }
  layers.plans.innerHTML = plans.join("");
  layers.trails.innerHTML = trails.join("");
  layers.vehicles.innerHTML = vehicles.join("");

  const paths = [], dots = [];  // every trail and prediction under every track's ellipse and dot
  for (const t of tracks.tracks) {
    const id = esc(t.target_id);
    paths.push(fadingTrail("track-trail", [...t.trail, [t.x, t.y, seconds(t.stamp_ns)]], newestS, `data-target="${id}"`));
    if (t.prediction.length) {
      paths.push(`<polyline id="prediction-${id}" class="prediction" data-points="${t.prediction.length}" points="${pts([[t.x, t.y], ...t.prediction.map((p) => [p.x, p.y])])}"/>`);
      for (const p of t.prediction) paths.push(ellipse("prediction-ellipse", p.x, p.y, p.ellipse));
    }
    dots.push(`<g id="track-${id}" class="track" data-target="${id}" data-x="${t.x}" data-y="${t.y}" data-seq="${t.seq}" ` +
      `data-stamp="${t.stamp_ns}" data-rx="${t.ellipse.rx}" data-ry="${t.ellipse.ry}">` + ellipse("track-ellipse", t.x, t.y, t.ellipse) +
      `<circle class="track-dot" cx="${t.x}" cy="${-t.y}" r="${4 * unit}"/></g>`);
    labelItems.push({ key: `track-${id}`, x: t.x, y: -t.y, text: t.target_id, weight: 600, r: MARK_PX.track, cls: "track-label" });
    marks.push({ x: t.x, y: -t.y, r: MARK_PX.track });
  }
  layers.track.innerHTML = paths.join("") + dots.join("");
  drawFederationAreas(tracks.federation, unit);  // a federation member's: federation.js
  drawFederationTargets(tracks.federation, unit, labelItems, marks);
  drawLabels(labelItems, marks, unit);
  drawScaleBar(unit);
  drawVehicleLegend(tracks.vehicles);
}

function drawLabels(items, marks, unit) {
  const places = placeLabels(items, marks, unit), parts = [];
  items.forEach((item, i) => {
    const p = places[i];
    if (p.leader) parts.push(`<line class="leader" x1="${p.leader[0]}" y1="${p.leader[1]}" x2="${p.leader[2]}" y2="${p.leader[3]}"/>`);
    parts.push(`<text class="label ${item.cls}" data-for="${item.key}" x="${p.x}" y="${p.y}" font-size="${LABEL_PX * unit}"` +
      `${item.fill ? ` fill="${item.fill}"` : ""}>${esc(item.text)}</text>`);
  });
  layers.labels.innerHTML = parts.join("");
}

// The tracks a detecting vehicle's sight lines go to: those its detections went into (their `contributing`); none
// when they went into none (clutter, or a report late).
function sightTargets(vehicle, tracks) {
  return tracks.filter((t) => t.contributing.includes(vehicle.id));
}

function drawScaleBar(unit) {
  const v = visibleBox();
  const want = 120 * unit;
  const step = Math.pow(10, Math.floor(Math.log10(want)));
  const length = [5, 2, 1].map((m) => m * step).find((l) => l <= want) || step;
  const x = v.x + 20 * unit, y = v.y + v.h - 20 * unit;
  document.getElementById("scale-bar").innerHTML =
    `<line class="scale-bar" x1="${x}" y1="${y}" x2="${x + length}" y2="${y}"/>` +
    `<text x="${x}" y="${y - 6 * unit}" font-size="${12 * unit}">${length >= 1000 ? length / 1000 + " km" : length + " m"}</text>`;
}

function drawVehicleLegend(vehicles) {
  const entries = vehicles.map((v) =>
    `<span class="legend-vehicle" data-id="${esc(v.id)}"><span class="swatch" style="background: ${vehicleColour(v.id)}"></span>${esc(v.id)}</span>`);
  const html = entries.join(" ");
  if (html !== legendHtml) document.getElementById("legend-vehicles").innerHTML = legendHtml = html;
}
let legendHtml = "";
