"""Every track on the live map: ``gcs replay --view`` of recordings of many tracks in headless Chromium.

The page must draw each track with a visible ellipse and a label showing its id,
list every track in the panel, and draw each detecting vehicle's sight lines to the
tracks it contributed to (none when it contributed to none); labels must not overlap. The
expected values are the recording's own last tracks: of a recording written message by
message, and of the daemon's flight through ``multitarget_urban``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from gcs.adapters.recording import read_recording
from gcs.config.world import build_world
from gcs.adapters.live_map.picture import TRACK_STALE_STEPS
from gcs.recordings.replay import key_kind
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.messages import TrackEstimate
from tests.e2e.browser import Browser, chromium_binary
from tests.e2e.processes import script
from tests.e2e.test_live_map import _Command, _screenshot
from tests.integration.daemon_flight import daemon_through_a_flight
from tests.integration.tracks_recording import SCENARIO_NAME, STEPS, UAVS, tracks_recording

TRACKS_STATE = """JSON.stringify((() => {
  const box = (e) => { const r = e.getBoundingClientRect(); return {x: r.x + r.width / 2, y: r.y + r.height / 2,
                                                                   w: r.width, h: r.height}; };
  const label = (id) => document.querySelector(`#layer-labels .label[data-for="${id}"]`);
  return {
    tracks: [...document.querySelectorAll('#layer-track .track')].map((g) => ({
      id: g.id, target: g.dataset.target, x: Number(g.dataset.x), y: Number(g.dataset.y), seq: Number(g.dataset.seq),
      rx: Number(g.dataset.rx), ry: Number(g.dataset.ry), ellipse: box(g.querySelector('.track-ellipse')),
      dot: box(g.querySelector('.track-dot')), label: label(g.id)?.textContent ?? null,
      label_box: label(g.id) && box(label(g.id))})),
    labels: [...document.querySelectorAll('#layer-labels .label')].map((e) => ({for: e.dataset.for, box: box(e)})),
    marks: [...document.querySelectorAll('#layer-vehicles .vehicle-body, #layer-track .track-dot, #layer-truth .truth')]
      .map(box),
    sights: [...document.querySelectorAll('#layer-vehicles .vehicle')].map((v) => ({
      id: v.id, x: Number(v.dataset.x), y: Number(v.dataset.y), detected: v.dataset.detected,
      lines: [...v.querySelectorAll('.sight')].map((l) => ({track: l.dataset.track,
        x1: Number(l.getAttribute('x1')), y1: Number(l.getAttribute('y1')),
        x2: Number(l.getAttribute('x2')), y2: Number(l.getAttribute('y2'))}))})),
    count: document.getElementById('track-count').textContent,
    rows: [...document.querySelectorAll('#track-list tbody tr')].map((r) => ({
      target: r.dataset.target ?? null, cells: [...r.cells].map((c) => c.textContent)})),
  };
})())"""


def _tracks_state(browser: Browser) -> dict:
    return json.loads(browser.evaluate(TRACKS_STATE))


def _viewed_at_end(recording: Path, scenario: str, folder: Path, screenshot: str) -> tuple[dict, dict]:
    """The page's tracks once ``gcs replay --view`` has played the whole recording, and its panel
    rendered without tracks (rendered and read in one task: no snapshot comes in between)."""
    binary = chromium_binary()
    viewer = _Command([script("gcs"), "replay", str(recording), "--view", "--scenario", scenario,
                       "--http", "127.0.0.1:0", "--rate", "4"], folder / "viewer.log")
    try:
        url = viewer.live_map_url()
        with Browser(binary) as browser:
            browser.open(url)
            browser.wait_for("!document.getElementById('replay-end').hidden && "
                             "document.getElementById('map').dataset.moving !== 'true'", 90.0, "the end of the recording")
            state = _tracks_state(browser)
            _screenshot(browser, screenshot)
            empty = json.loads(browser.evaluate(
                "renderTrackSummary({tracks: []}); JSON.stringify({count: document.getElementById('track-count')"
                ".textContent, rows: [...document.querySelectorAll('#track-list tbody tr')].map((r) => r.textContent)})"))
    finally:
        code, _, stderr = viewer.finish()  # it runs until Ctrl-C
    assert code == 130, stderr[-3000:]  # stopped by Ctrl-C
    return state, empty


def _overlap(a: dict, b: dict) -> bool:
    return abs(a["x"] - b["x"]) < (a["w"] + b["w"]) / 2 and abs(a["y"] - b["y"]) < (a["h"] + b["h"]) / 2


def _assert_drawn_and_listed(state: dict, expected: dict[str, TrackEstimate]) -> dict[str, dict]:
    """Each expected track drawn (visible ellipse about its dot, its id beside it, the recorded position,
    seq and 2-sigma semi-axes) and listed in the panel, and nothing else; the drawn tracks by id."""
    drawn = {t["target"]: t for t in state["tracks"]}
    assert sorted(drawn) == sorted(expected), state["tracks"]
    for target_id, estimate in expected.items():
        t = drawn[target_id]
        assert t["id"] == f"track-{target_id}" and t["label"] == target_id
        assert t["seq"] == estimate.seq
        assert (t["x"], t["y"]) == pytest.approx(estimate.state[:2], abs=0.06)  # the map's decimetres
        n = len(estimate.state)
        minor, major = np.linalg.eigvalsh(np.asarray(estimate.covariance).reshape(n, n)[:2, :2])
        assert (t["rx"], t["ry"]) == pytest.approx((2 * math.sqrt(major), 2 * math.sqrt(minor)), abs=0.06)
        assert t["ellipse"]["w"] > 1 and t["ellipse"]["h"] > 1, t  # visible on screen
        assert math.dist((t["ellipse"]["x"], t["ellipse"]["y"]), (t["dot"]["x"], t["dot"]["y"])) < 1.0  # centred
        label = t["label_box"]
        assert label["w"] > 0 and label["h"] > 0
        assert math.dist((label["x"], label["y"]), (t["dot"]["x"], t["dot"]["y"])) < 60.0  # beside its dot (px)
    labels = [label["box"] for label in state["labels"]]  # the tracks' and the vehicles'
    assert sorted(label["for"] for label in state["labels"]) == sorted(
        [f"track-{k}" for k in expected] + [s["id"] for s in state["sights"]])
    assert not any(_overlap(a, b) for i, a in enumerate(labels) for b in labels[i + 1:]), labels  # each readable
    assert not any(_overlap(label, mark) for label in labels for mark in state["marks"]), (labels, state["marks"])

    assert state["count"] == str(len(expected))
    rows = {r["target"]: r["cells"] for r in state["rows"]}
    assert sorted(rows) == sorted(expected) and len(state["rows"]) == len(expected)
    for target_id, estimate in expected.items():
        identity, position, speed, axes, seen_by = rows[target_id]
        assert identity == target_id
        shown = re.fullmatch(r"\((-?\d+), (-?\d+)\)", position)
        assert shown, position
        assert [float(v) for v in shown.groups()] == pytest.approx(estimate.state[:2], abs=0.56)  # 0.1 m, shown to 1 m
        assert float(speed) == pytest.approx(math.hypot(*estimate.state[2:4]), abs=0.06)  # 0.01, shown to 0.1
        assert axes == f"{drawn[target_id]['rx']:.1f} x {drawn[target_id]['ry']:.1f}"
        assert seen_by == (", ".join(estimate.contributing_vehicles) or "predicted")
    return drawn


def test_replay_view_draws_every_track_with_its_ellipse_and_id_and_lists_them(tmp_path: Path) -> None:
    recording = tmp_path / "tracks.mcap"
    last = tracks_recording(recording)
    state, empty = _viewed_at_end(recording, SCENARIO_NAME, tmp_path, "live_map_tracks.png")
    assert empty == {"count": "0", "rows": ["none yet"]}
    assert sorted(last) == ["t1", "t2", "t3"] and all(t.seq == STEPS for t in last.values())
    drawn = _assert_drawn_and_listed(state, last)  # with labels apart
    dot = {k: (t["dot"]["x"], t["dot"]["y"]) for k, t in drawn.items()}
    assert math.dist(dot["t1"], dot["t2"]) > 40.0 and math.dist(dot["t1"], dot["t3"]) < 5.0  # px: t3 is beside t1

    sights = {s["id"].removeprefix("vehicle-"): s for s in state["sights"]}
    assert sorted(sights) == sorted(UAVS)
    expected = {v: sorted(k for k, e in last.items() if v in e.contributing_vehicles) for v in UAVS}
    assert expected == {"uav1": ["t1", "t2"], "uav2": ["t1"], "uav3": []}  # uav3 detects, but fed no track
    assert sights["uav3"]["detected"] == "true"
    for vehicle_id, s in sights.items():
        assert sorted(line["track"] for line in s["lines"]) == expected[vehicle_id], s
        for line in s["lines"]:  # from the vehicle to its track (SVG y is -north)
            assert (line["x1"], -line["y1"]) == pytest.approx((s["x"], s["y"]))
            assert (line["x2"], -line["y2"]) == pytest.approx((drawn[line["track"]]["x"], drawn[line["track"]]["y"]))


def test_replay_view_of_a_multitarget_flight_draws_each_confirmed_track(tmp_path: Path) -> None:
    scenario = load_scenario("multitarget_urban")
    recording = tmp_path / "flight.mcap"
    with daemon_through_a_flight(scenario, build_world(scenario), recording, seed=5, duration_s=40.0, rate=5.0,
                                 epoch_ns=10**12):
        pass
    last: dict[str, TrackEstimate] = {}
    for record in read_recording(recording):
        if "/track/" in record.key:
            track = decode(record.payload, record.encoding, TrackEstimate)
            if track.target_id not in last or track.stamp_ns >= last[track.target_id].stamp_ns:
                last[track.target_id] = track
    newest_ns = max(r.publish_time_ns for r in read_recording(recording)  # the newest stamp the map has seen
                    if key_kind(r.key)[0] in ("report", "nav", "truth", "track"))
    stale_ns = round(TRACK_STALE_STEPS * load_scenario("multitarget_urban").time.step_s * 1e9)
    on_map = {k: t for k, t in last.items() if t.stamp_ns >= newest_ns - stale_ns}  # the rest were deleted
    assert len(on_map) >= 2 and all(re.fullmatch(r"t[0-9]+", k) for k in on_map), sorted(last)
    state, _ = _viewed_at_end(recording, "multitarget_urban", tmp_path, "live_map_multitarget.png")
    _assert_drawn_and_listed(state, on_map)
