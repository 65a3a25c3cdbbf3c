// gcs live map: the data flow (/api/world once, then every snapshot of /events, Server-Sent Events), the panel,
// the header's clock and the replay controls. Testable state: <body data-snapshots data-connected data-mode>,
// the clock's data-seconds, the progress bar's value.
"use strict";

const SPEEDS = new Set([0.5, 1, 2, 5, 10, 20, 50, 100]);  // the speed list; the replay's own speed is added to it

// The one clock on the page: flight time, the stamp time since the first message, as m:ss (h:mm:ss past an hour).
function flightTime(seconds) {
  if (seconds === null) return "-";
  const whole = Math.max(0, Math.floor(seconds)), h = Math.floor(whole / 3600), m = Math.floor(whole / 60) % 60;
  const ss = String(whole % 60).padStart(2, "0");
  return h ? `${h}:${String(m).padStart(2, "0")}:${ss}` : `${m}:${ss}`;
}

function renderStatus(status, truths) {
  document.body.dataset.mode = status.mode;
  document.getElementById("scenario").textContent = `${status.scenario} (${status.mode})`;
  const t = status.stamp_ns === null ? null : (status.stamp_ns - status.first_stamp_ns) / 1e9;
  const clock = document.getElementById("clock");
  clock.textContent = `flight time ${flightTime(t)}`;
  clock.dataset.seconds = t === null ? "" : String(t);
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
  document.getElementById("replay-controls").hidden = !status.replay;
  if (status.replay) renderReplay(status.replay);
}

// Play/pause, the speed list (always holding the replay's speed, e.g. --rate 4) and how far the replay has played.
function renderReplay(replay) {
  document.getElementById("play").textContent = replay.playing ? "pause" : "play";
  const speed = document.getElementById("speed");
  if (!SPEEDS.has(replay.speed) || speed.options.length !== SPEEDS.size) {
    SPEEDS.add(replay.speed);
    speed.innerHTML = [...SPEEDS].sort((a, b) => a - b).map((s) => `<option value="${s}">${s}\u00d7</option>`).join("");
  }
  if (document.activeElement !== speed) speed.value = String(replay.speed);
  const progress = document.getElementById("replay-progress");
  if (replay.duration_s) progress.value = replay.ended ? 1 : Math.min(1, replay.position_s / replay.duration_s);
  else progress.removeAttribute("value");
  document.getElementById("replay-end").hidden = !replay.ended;
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

function onSnapshot(snapshot) {
  if (!snapshot.tracks || !snapshot.status) return;
  state.tracks = snapshot.tracks;
  state.snapshots += 1;
  renderStatus(snapshot.status, snapshot.tracks.truth.length);
  renderTrackSummary(snapshot.tracks);
  if (state.look === "follow") follow(false);
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
const trailLength = document.getElementById("trail-length");
state.trailS = Number(trailLength.value);
trailLength.addEventListener("change", () => { state.trailS = Number(trailLength.value); render(); });

fetch("api/world").then((r) => r.json()).then((world) => {
  state.world = world;
  drawWorld(world);
  follow(true);
  connect();
});
