// gcs live map: where the labels go, so that none covers another label or a mark (a vehicle, a track's dot, a
// truth's cross). Work is in screen pixels: a label is LABEL_PX high whatever the zoom. Each label tries the places
// about its anchor, nearest ring first (right, left, above, below and the four corners), and takes the first that
// is free; when none is, the one overlapping least. A label placed beyond the first ring gets a leader line.
"use strict";

const LABEL_PX = 12;
const LABEL_PAD_PX = 2;    // clear space kept about every label box
const LABEL_GAP_PX = 3;    // from a mark's edge to its label
const LABEL_RING_PX = 14;  // each further ring is this much further out
const LABEL_RINGS = 6;

const measureContext = document.createElement("canvas").getContext("2d");

// Width, ascent and descent (px) of a label as the page's CSS draws it (svg text: system-ui, LABEL_PX).
function textSize(text, weight) {
  measureContext.font = `${weight} ${LABEL_PX}px system-ui, sans-serif`;
  const m = measureContext.measureText(text);
  return { w: m.width, ascent: m.fontBoundingBoxAscent || 0.8 * LABEL_PX, descent: m.fontBoundingBoxDescent || 0.25 * LABEL_PX };
}

function overlapArea(a, b) {
  const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
  const h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  return w > 0 && h > 0 ? w * h : 0;
}

// Boxes (px, top-left x, y) for a label of size (w, h) about an anchor (ax, ay) whose mark has radius r, nearest first.
function candidates(ax, ay, r, w, h) {
  const out = [];
  for (let ring = 0; ring < LABEL_RINGS; ring++) {
    const g = r + LABEL_GAP_PX + ring * LABEL_RING_PX;
    out.push(
      { x: ax + g, y: ay - h / 2, ring }, { x: ax - g - w, y: ay - h / 2, ring },
      { x: ax - w / 2, y: ay - g - h, ring }, { x: ax - w / 2, y: ay + g, ring },
      { x: ax + g, y: ay - g - h, ring }, { x: ax + g, y: ay + g, ring },
      { x: ax - g - w, y: ay - g - h, ring }, { x: ax - g - w, y: ay + g, ring });
  }
  return out;
}

// items: [{key, x, y (SVG coordinates), text, weight, r (its mark's radius, px)}], marks: [{x, y, r}] (the same
// coordinates; every item's own mark among them). Returns per item {x, y} of its text (SVG, baseline start),
// box (SVG) and leader ([x1, y1, x2, y2] from the anchor to the box, or null).
function placeLabels(items, marks, unit) {
  const taken = marks.map((m) => ({ x: m.x / unit - m.r, y: m.y / unit - m.r, w: 2 * m.r, h: 2 * m.r }));
  return items.map((item) => {
    const size = textSize(item.text, item.weight), w = size.w, h = size.ascent + size.descent;
    const ax = item.x / unit, ay = item.y / unit;
    let best = null, bestCost = Infinity;
    for (const c of candidates(ax, ay, item.r, w, h)) {
      const padded = { x: c.x - LABEL_PAD_PX, y: c.y - LABEL_PAD_PX, w: w + 2 * LABEL_PAD_PX, h: h + 2 * LABEL_PAD_PX };
      const cost = taken.reduce((sum, box) => sum + overlapArea(padded, box), 0);
      if (cost < bestCost) { best = c; bestCost = cost; }
      if (cost === 0) break;
    }
    taken.push({ x: best.x - LABEL_PAD_PX, y: best.y - LABEL_PAD_PX, w: w + 2 * LABEL_PAD_PX, h: h + 2 * LABEL_PAD_PX });
    const nearX = Math.min(Math.max(ax, best.x), best.x + w), nearY = Math.min(Math.max(ay, best.y), best.y + h);
    const d = Math.max(Math.hypot(nearX - ax, nearY - ay), 1e-9), fromX = ax + (nearX - ax) * item.r / d;
    const fromY = ay + (nearY - ay) * item.r / d;  // the leader starts at the mark's edge
    return {
      x: best.x * unit, y: (best.y + size.ascent) * unit,
      box: { x: best.x * unit, y: best.y * unit, w: w * unit, h: h * unit },
      leader: best.ring > 0 ? [fromX * unit, fromY * unit, nearX * unit, nearY * unit] : null,
    };
  });
}
