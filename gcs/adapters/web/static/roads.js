// gcs live map: the world's roads (/api/world's roads, polylines in ENU metres), under the buildings.
// All the roads are one <path class="road"> in <g id="layer-roads" data-roads data-segments> (one element, however
// large the graph); a one-way road has chevrons pointing its driving sense (<g id="road-arrows">, drawn again when the
// view changes, every ARROW_EVERY_PX along a one-way road on screen). The legend's checkbox #show-roads hides the
// layer (<body data-roads="shown" | "hidden" | "none">, none for a world without roads).
"use strict";

const ARROW_EVERY_PX = 120;  // one chevron per this much one-way road on screen...
const ARROW_MIN_PX = 30;     // ...and none on a road shorter than this on screen
const ARROW_PX = 4;          // half the chevron's length on screen
const roads = { oneWay: [], arrowsFor: "" };

// The SVG of the roads layer (SVG coordinates: y is -north), and the one-way roads kept for the chevrons: each as its
// points [x, y, arc length from its start].
function roadsMarkup(world) {
  const lines = world.roads || [];
  roads.oneWay = [];
  let segments = 0;
  const d = lines.map((road) => {
    segments += road.line.length - 1;
    if (road.one_way) {
      let along = 0;
      roads.oneWay.push(road.line.map((p, i) => {
        if (i) along += Math.hypot(p[0] - road.line[i - 1][0], p[1] - road.line[i - 1][1]);
        return [p[0], -p[1], along];
      }));
    }
    return "M" + road.line.map((p) => p[0] + "," + -p[1]).join("L");
  }).join("");
  roads.arrowsFor = "";
  document.getElementById("legend-roads").hidden = !lines.length;
  return `<g id="layer-roads" data-roads="${lines.length}" data-segments="${segments}"${roadsShown() ? "" : ' style="display: none"'}>` +
    (lines.length ? `<path class="road" d="${d}"/>` : "") + `<g id="road-arrows"></g></g>`;
}

function roadsShown() {
  return document.getElementById("show-roads").checked;
}

function showRoads() {
  const layer = document.getElementById("layer-roads");
  if (layer) layer.style.display = roadsShown() ? "" : "none";
  const none = !state.world || !(state.world.roads || []).length;
  document.body.dataset.roads = none ? "none" : roadsShown() ? "shown" : "hidden";
}

// Chevrons along the one-way roads on screen, every ARROW_EVERY_PX from half that from a road's start, each ARROW_PX
// about its point and pointing the way the road is driven.
function drawRoadArrows() {
  const group = document.getElementById("road-arrows");
  if (!group || !state.view || !roads.oneWay.length) return;
  const unit = metresPerPixel(), vis = visibleBox();
  const key = [vis.x, vis.y, vis.w, vis.h].map((v) => v.toFixed(1)).join(" ");
  if (key === roads.arrowsFor) return;  // the same view: the same chevrons
  roads.arrowsFor = key;
  const s = ARROW_PX * unit, every = ARROW_EVERY_PX * unit, parts = [];
  for (const road of roads.oneWay) {
    const length = road[road.length - 1][2];
    if (length < ARROW_MIN_PX * unit) continue;
    let i = 1;
    for (let at = Math.min(every, length) / 2; at < length; at += every) {
      while (road[i][2] < at) i++;
      const [ax, ay, sa] = road[i - 1], [bx, by, sb] = road[i], f = (at - sa) / (sb - sa);
      const x = ax + f * (bx - ax), y = ay + f * (by - ay);
      if (x < vis.x || x > vis.x + vis.w || y < vis.y || y > vis.y + vis.h) continue;
      const ux = (bx - ax) / (sb - sa), uy = (by - ay) / (sb - sa);
      parts.push(`M${x - s * (ux + 0.8 * uy)},${y - s * (uy - 0.8 * ux)}L${x + s * ux},${y + s * uy}` +
        `L${x - s * (ux - 0.8 * uy)},${y - s * (uy + 0.8 * ux)}`);
    }
  }
  group.innerHTML = parts.length ? `<path class="road-arrow" d="${parts.join("")}"/>` : "";
}

document.getElementById("show-roads").addEventListener("change", showRoads);
