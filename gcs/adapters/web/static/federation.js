// gcs live map: a federation member's whole picture (the tracks document's `federation` part): every member's area,
// a thin rectangle labelled with its id, and every target of the federation by global id, a diamond with its 2-sigma
// ellipse labelled with the id and its holders; a lost target dashed and faded, one this member plans for
// highlighted. Testable state: an area's rect carries data-member and data-own; a target's group data-global-id,
// data-x, data-y, data-rx, data-ry, data-holders (comma-separated), data-lost and data-claim (empty when unclaimed).
"use strict";

const FED_MARK_PX = 6;  // half the diagonal of a global target's diamond on screen

function drawFederationAreas(federation, unit) {
  const layer = layers["federation-areas"];
  document.querySelectorAll(".legend-federation").forEach((li) => { li.hidden = !federation; });
  if (!federation) { layer.innerHTML = ""; return; }
  layer.innerHTML = federation.members.map((m) => {
    const [x0, y0, x1, y1] = m.area, id = esc(m.id);
    return `<rect class="fed-area${m.own ? " own" : ""}" data-member="${id}" data-own="${m.own}" x="${x0}" y="${-y1}" ` +
      `width="${x1 - x0}" height="${y1 - y0}"><title>${id}: ${m.vehicles} vehicles, ${m.spare} spare</title></rect>` +
      `<text class="fed-area-label" data-for="area-${id}" x="${x0 + 6 * unit}" y="${-y1 + (LABEL_PX + 4) * unit}" ` +
      `font-size="${LABEL_PX * unit}">${id} (${m.vehicles} vehicles, ${m.spare} spare)</text>`;
  }).join("");
}

// The global targets into #layer-federation; their labels and marks join the page's (labels.js places them all).
function drawFederationTargets(federation, unit, labelItems, marks) {
  const layer = layers.federation;
  if (!federation) { layer.innerHTML = ""; return; }
  const s = FED_MARK_PX * unit;
  layer.innerHTML = federation.targets.map((t) => {
    const id = esc(t.global_id), cls = `fed-target${t.lost ? " lost" : ""}${t.claim ? " claimed" : ""}`;
    labelItems.push({ key: `fed-${id}`, x: t.x, y: -t.y, text: `${t.global_id} \u00b7 ${t.holders.join(", ") || "lost"}`,
                      weight: t.claim ? 600 : 400, r: FED_MARK_PX, cls: "fed-label" });
    marks.push({ x: t.x, y: -t.y, r: FED_MARK_PX });
    return `<g class="${cls}" data-global-id="${id}" data-x="${t.x}" data-y="${t.y}" data-rx="${t.ellipse.rx}" ` +
      `data-ry="${t.ellipse.ry}" data-holders="${esc(t.holders.join(","))}" data-lost="${t.lost}" data-claim="${esc(t.claim || "")}">` +
      `<title>${id}: ${t.lost ? "lost" : "held by " + esc(t.holders.join(", "))}${t.claim ? "; planned for here (" + esc(t.claim) + ")" : ""}</title>` +
      ellipse("fed-ellipse", t.x, t.y, t.ellipse) +
      `<path class="fed-mark" d="M${t.x},${-t.y - s}L${t.x + s},${-t.y}L${t.x},${-t.y + s}L${t.x - s},${-t.y}Z"/></g>`;
  }).join("");
}
