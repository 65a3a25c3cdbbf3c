"""Every track on the live map: ``gcs replay --view`` of a two-track recording in headless Chromium.

The page must draw each track with a visible ellipse and a label showing its id,
list every track in the panel, and draw each detecting vehicle's sight lines to the
tracks it contributed to (or to the nearest track). The expected values are the
recording's own last tracks.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.e2e.browser import Browser, chromium_binary
from tests.e2e.processes import script
from tests.e2e.test_live_map import _Command, _screenshot
from tests.integration.two_tracks import SCENARIO_NAME, STEPS, UAVS, two_track_recording

TRACKS_STATE = """JSON.stringify((() => {
  const box = (e) => { const r = e.getBoundingClientRect(); return {x: r.x + r.width / 2, y: r.y + r.height / 2,
                                                                   w: r.width, h: r.height}; };
  return {
    position: document.getElementById('replay-position').textContent,
    tracks: [...document.querySelectorAll('#layer-track .track')].map((g) => ({
      id: g.id, target: g.dataset.target, x: Number(g.dataset.x), y: Number(g.dataset.y), seq: Number(g.dataset.seq),
      rx: Number(g.dataset.rx), ry: Number(g.dataset.ry), ellipse: box(g.querySelector('.track-ellipse')),
      dot: box(g.querySelector('.track-dot')), label: g.querySelector('.track-label')?.textContent ?? null,
      label_box: g.querySelector('.track-label') && box(g.querySelector('.track-label'))})),
    sights: [...document.querySelectorAll('#layer-vehicles .vehicle')].map((v) => ({
      id: v.id, x: Number(v.dataset.x), y: Number(v.dataset.y),
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


def test_replay_view_draws_every_track_with_its_ellipse_and_id_and_lists_them(tmp_path: Path) -> None:
    binary = chromium_binary()
    recording = tmp_path / "two_tracks.mcap"
    last = two_track_recording(recording)
    viewer = _Command([script("gcs"), "replay", str(recording), "--view", "--scenario", SCENARIO_NAME,
                       "--http", "127.0.0.1:0", "--rate", "4"], tmp_path / "viewer.log")
    try:
        url = viewer.live_map_url()
        with Browser(binary) as browser:
            browser.open(url)
            browser.wait_for("document.getElementById('replay-position').textContent.includes('(end)')", 60.0,
                             "the end of the recording")
            state = _tracks_state(browser)
            _screenshot(browser, "live_map_tracks.png")
            # the panel without tracks (rendered and read in one task: no snapshot comes in between)
            empty = json.loads(browser.evaluate(
                "renderTrackSummary({tracks: []}); JSON.stringify({count: document.getElementById('track-count')"
                ".textContent, rows: [...document.querySelectorAll('#track-list tbody tr')].map((r) => r.textContent)})"))
    finally:
        code, _, stderr = viewer.finish()  # it runs until Ctrl-C
    assert code == 0, stderr[-3000:]
    assert empty == {"count": "0", "rows": ["none yet"]}

    drawn = {t["target"]: t for t in state["tracks"]}
    assert sorted(drawn) == sorted(last) == ["t1", "t2"], state["tracks"]
    for target_id, estimate in last.items():
        t = drawn[target_id]
        assert t["id"] == f"track-{target_id}" and t["label"] == target_id
        assert t["seq"] == estimate.seq == STEPS
        assert (t["x"], t["y"]) == pytest.approx(estimate.state[:2], abs=0.06)  # the map's decimetres
        cov = np.asarray(estimate.covariance).reshape(4, 4)[:2, :2]
        minor, major = np.linalg.eigvalsh(cov)
        assert (t["rx"], t["ry"]) == pytest.approx((2 * math.sqrt(major), 2 * math.sqrt(minor)), abs=0.06)
        assert t["ellipse"]["w"] > 1 and t["ellipse"]["h"] > 1, t  # visible on screen
        assert math.dist((t["ellipse"]["x"], t["ellipse"]["y"]), (t["dot"]["x"], t["dot"]["y"])) < 1.0  # centred
        label = t["label_box"]
        assert label["w"] > 0 and label["h"] > 0
        assert math.dist((label["x"], label["y"]), (t["dot"]["x"], t["dot"]["y"])) < 40.0  # beside its dot (px)
    first, second = (drawn[k]["dot"] for k in sorted(drawn))
    assert math.dist((first["x"], first["y"]), (second["x"], second["y"])) > 40.0  # two places on screen

    assert state["count"] == "2"
    rows = {r["target"]: r["cells"] for r in state["rows"]}
    assert sorted(rows) == ["t1", "t2"]
    for target_id, estimate in last.items():
        identity, position, speed, axes, seen_by = rows[target_id]
        assert identity == target_id
        assert position == f"({estimate.state[0]:.0f}, {estimate.state[1]:.0f})"
        assert float(speed) == pytest.approx(math.hypot(*estimate.state[2:4]), abs=0.05)
        assert axes == f"{drawn[target_id]['rx']:.1f} x {drawn[target_id]['ry']:.1f}"
        assert seen_by == ", ".join(estimate.contributing_vehicles)

    sights = {s["id"].removeprefix("vehicle-"): s for s in state["sights"]}
    assert sorted(sights) == sorted(UAVS)
    fed = {v: sorted(k for k, e in last.items() if v in e.contributing_vehicles) for v in UAVS}
    nearest = min(last, key=lambda k: math.dist(last[k].state[:2], (sights["uav3"]["x"], sights["uav3"]["y"])))
    assert fed["uav3"] == [] and nearest == "t2"
    expected = {**fed, "uav3": [nearest]}
    assert expected == {"uav1": ["t1", "t2"], "uav2": ["t1"], "uav3": ["t2"]}  # both ways of choosing are seen
    for vehicle_id, s in sights.items():
        assert sorted(line["track"] for line in s["lines"]) == expected[vehicle_id], s
        for line in s["lines"]:  # from the vehicle to its track (SVG y is -north)
            assert (line["x1"], -line["y1"]) == pytest.approx((s["x"], s["y"]))
            assert (line["x2"], -line["y2"]) == pytest.approx((drawn[line["track"]]["x"], drawn[line["track"]]["y"]))
