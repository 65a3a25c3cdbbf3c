"""What the live map shows, looked at in headless Chromium's screenshots: ``gcs replay --view`` of a scripted scene.

The scene (:func:`_scene`, ``wang2012_urban``'s city and vehicle ids): the target drives east at 6 m/s from
(1000, 1500); the three UAVs circle it at 150, 250 and 350 m and 20 m/s, uav1 spiralling in over its last
30 s until it is right above the target at the end (where its label and the target's would fall on each
other). Every position is known from the script, and the tests check the page against it: the first view
frames the vehicles and the target and not the whole city; the view follows them; "whole city" shows the city;
each vehicle's pixels have the colour the legend gives it; the trails fade with age and are gone past the
trail time; no label covers another label or a mark; the speed list shows ``--rate 4``; the header shows one
clock. Screenshots are saved under ``tests/artifacts/``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from gcs.adapters.recording import Recorder
from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, plan_key, report_key, track_key, truth_key
from protocols.messages import NavReport, PlanCommand, PredictedPoint, TargetTruth, TrackEstimate
from protocols.sensor_report import Measurement, SensorReport
from tests.e2e.browser import (ARTIFACTS, Browser, assert_colours_as_the_legend, assert_labels_apart, chromium_binary,
                               followed, inside, page_geometry, rgb, settled)
from tests.e2e.processes import script
from tests.e2e.test_live_map import _Command

SCENARIO_NAME = "wang2012_urban"
CITY_M = tuple(build_world(load_scenario(SCENARIO_NAME)).size_m)
NS = 1_000_000_000
EPOCH_NS = 1_700_000_000 * NS
STEPS = 150
TARGET_START, TARGET_SPEED = (1000.0, 1500.0), 6.0
RADII = {"uav1": 150.0, "uav2": 250.0, "uav3": 350.0}
UAV_SPEED, SPIRAL_STEPS = 20.0, 30
TRACK_OFFSET = (3.0, -2.0)  # the track's error: it sits this far from the truth


def _target(k: float) -> tuple[float, float]:
    return TARGET_START[0] + TARGET_SPEED * k, TARGET_START[1]


def _uav(vehicle_id: str, k: float) -> tuple[float, float, float]:
    """(x, y, heading) of a UAV at step ``k``: on its circle about the target, uav1 spiralling in at the end."""
    index = list(RADII).index(vehicle_id)
    radius = RADII[vehicle_id]
    angle = 2 * math.pi * index / 3 + UAV_SPEED / radius * k
    if vehicle_id == "uav1":
        radius *= min(1.0, (STEPS - 1 - k) / SPIRAL_STEPS)
    tx, ty = _target(k)
    return tx + radius * math.cos(angle), ty + radius * math.sin(angle), angle + math.pi / 2


def _track_at(k: int) -> TrackEstimate:
    x, y = (a + b for a, b in zip(_target(k), TRACK_OFFSET))
    stamp = EPOCH_NS + k * NS
    covariance = (64.0, 0, 0, 0, 0, 36.0, 0, 0, 0, 0, 4.0, 0, 0, 0, 0, 4.0)
    prediction = tuple(PredictedPoint(stamp_ns=stamp + j * NS, position_enu_m=(x + TARGET_SPEED * j, y),
                                      position_cov_m2=(64.0 + 9 * j, 0.0, 0.0, 36.0 + 9 * j)) for j in (1, 2, 3))
    return TrackEstimate(target_id="target", seq=k + 1, stamp_ns=stamp, model="cv2d", state=(x, y, TARGET_SPEED, 0.0),
                         covariance=covariance, contributing_vehicles=("uav1", "uav2"), prediction=prediction)


def _scene(path: Path) -> None:
    """Write the scene's recording: reports, nav, plans, truth and track every second of ``STEPS``."""
    with Recorder(path) as recorder:
        for vehicle_id in RADII:
            recorder.write_liveliness(alive_key(vehicle_id), True, EPOCH_NS - NS // 2)
        for k in range(STEPS):
            stamp = EPOCH_NS + k * NS
            for slot, vehicle_id in enumerate(RADII):
                x, y, heading = _uav(vehicle_id, k)
                seen = Measurement(range_m=300.0, range_std_m=10.0, azimuth_rad=0.3, azimuth_std_rad=0.05,
                                   elevation_rad=-0.7, elevation_std_rad=0.05)
                report = SensorReport(vehicle_id=vehicle_id, seq=k + 1, stamp_ns=stamp,
                                      vehicle_position_enu_m=(x, y, 200.0), detections=(seen,))
                nav = NavReport(vehicle_id=vehicle_id, seq=k + 1, stamp_ns=stamp, heading_rad=math.remainder(heading, 2 * math.pi),
                                velocity_enu_mps=(UAV_SPEED * math.cos(heading), UAV_SPEED * math.sin(heading), 0.0))
                plan = PlanCommand(vehicle_id=vehicle_id, seq=k + 1, stamp_ns=stamp, heading_rad=0.0, turn_rate_rad_s=0.0,
                                   airspeed_mps=UAV_SPEED, altitude_m=200.0, planner="scripted",
                                   planned_path_enu_m=tuple(_uav(vehicle_id, k + j)[:2] for j in (2, 4, 6, 8)))
                recorder.write(report_key(vehicle_id), *encode(report), stamp + slot * 10_000_000)
                recorder.write(nav_key(vehicle_id), *encode(nav), stamp + slot * 10_000_000 + 1)
                recorder.write(plan_key(vehicle_id), *encode(plan), stamp + 150_000_000)
            truth = TargetTruth(target_id="target", seq=k + 1, stamp_ns=stamp, position_enu_m=_target(k),
                                velocity_enu_mps=(TARGET_SPEED, 0.0))
            recorder.write(truth_key("target"), *encode(truth), stamp + 50_000_000)
            recorder.write(track_key("target"), *encode(_track_at(k)), stamp + 100_000_000)


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("scene") / "scene.mcap"
    _scene(path)
    return path


def _viewer(scene: Path, folder: Path, rate: float) -> _Command:
    return _Command([script("gcs"), "replay", str(scene), "--view", "--scenario", SCENARIO_NAME,
                     "--http", "127.0.0.1:0", "--rate", str(rate)], folder / "viewer.log")


def test_the_map_opens_on_the_vehicles_and_target_follows_them_and_shows_the_city_on_request(scene, tmp_path) -> None:
    viewer = _viewer(scene, tmp_path, rate=4)
    try:
        url = viewer.live_map_url()
        with Browser(chromium_binary()) as browser:
            browser.open(url)
            first = settled(browser, lambda g: len(g["vehicles"]) == 3 and g["tracks"] and g["truths"],
                             "the vehicles, the track and the truth")
            pixels = browser.pixels(ARTIFACTS / "live_map_view_first.png")

            # the speed list holds the replay's --rate; the header shows one clock, named, at the page's stamp
            assert (first["speed"], first["speed_text"]) == ("4", "4\u00d7")
            assert len(re.findall(r"\d+:\d\d|\d+(?:\.\d+)? s\b", first["header"])) == 1, first["header"]
            newest = max(v["stamp"] for v in first["vehicles"] + first["tracks"])
            assert first["clock_s"] == pytest.approx((newest - EPOCH_NS) / NS, abs=1e-6)
            minutes, seconds = divmod(int(first["clock_s"]), 60)
            assert first["clock"] == f"flight time {minutes}:{seconds:02d}"

            # the page draws the scene where the script put it
            for v in first["vehicles"]:
                k = (v["stamp"] - EPOCH_NS) / NS
                assert (v["x"], v["y"]) == pytest.approx(_uav(v["id"], k)[:2], abs=0.06)  # the map's decimetres
            (track,) = first["tracks"]
            assert (track["x"], track["y"]) == pytest.approx(_track_at(round((track["stamp"] - EPOCH_NS) / NS)).state[:2],
                                                             abs=0.06)

            # the first view frames the vehicles and the target, not the 3 km city
            shown = first["shown"]
            assert first["look"] == "follow" and first["follow_pressed"] == "true"
            assert shown["east"] - shown["west"] < CITY_M[0] / 2.5 and shown["north"] - shown["south"] < CITY_M[1] / 2.5
            assert all(inside(shown, x, y, 0.03) for x, y in followed(first)), (shown, followed(first))

            # every vehicle in its own colour, the one the legend gives it, which nothing else on the map uses
            assert sorted(first["legend"]) == ["uav1", "uav2", "uav3"]
            assert_colours_as_the_legend(first, pixels)

            # the view follows them east
            browser.evaluate("const s = document.getElementById('speed'); s.value = '20'; s.dispatchEvent(new Event('change'))")
            later = settled(browser, lambda g: g["tracks"] and g["tracks"][0]["x"] > track["x"] + 500, "the target 500 m further east")
            browser.pixels(ARTIFACTS / "live_map_view_followed.png")
            assert later["look"] == "follow"
            assert all(inside(later["shown"], x, y, 0.03) for x, y in followed(later)), (later["shown"], followed(later))
            centre = lambda s: ((s["west"] + s["east"]) / 2, (s["south"] + s["north"]) / 2)  # noqa: E731
            assert centre(later["shown"])[0] > centre(shown)[0] + 250

            # the whole city on request; a wheel zoom leaves following; "follow" frames them again
            browser.evaluate("document.getElementById('city').click()")
            city = settled(browser, lambda g: g["look"] == "city", "the whole city")
            browser.pixels(ARTIFACTS / "live_map_view_city.png")
            assert city["city_pressed"] == "true" and city["follow_pressed"] == "false"
            assert city["shown"]["west"] <= 0 and city["shown"]["south"] <= 0
            assert city["shown"]["east"] >= CITY_M[0] and city["shown"]["north"] >= CITY_M[1]
            assert city["shown"]["east"] - city["shown"]["west"] < 1.6 * CITY_M[0]
            browser.evaluate("const m = document.getElementById('map'), r = m.getBoundingClientRect(); m.dispatchEvent("
                             "new WheelEvent('wheel', {deltaY: -300, clientX: r.x + r.width / 2, clientY: r.y + r.height / 2,"
                             " bubbles: true, cancelable: true}))")
            free = settled(browser, lambda g: g["look"] == "free", "the view zoomed by hand")
            assert free["shown"]["east"] - free["shown"]["west"] < city["shown"]["east"] - city["shown"]["west"]
            browser.evaluate("document.getElementById('follow').click()")
            again = settled(browser, lambda g: g["look"] == "follow", "following again")
            assert again["shown"]["east"] - again["shown"]["west"] < CITY_M[0] / 2.5
            assert all(inside(again["shown"], x, y, 0.03) for x, y in followed(again))
    finally:
        code, _, stderr = viewer.finish()
    assert code == 130, stderr[-3000:]  # stopped with Ctrl-C, as a user does


@pytest.fixture(scope="module")
def at_the_end(scene, tmp_path_factory):
    """The page at the end of the scene (the replay pauses there), in a browser, and the viewer's log folder."""
    folder = tmp_path_factory.mktemp("end")
    viewer = _viewer(scene, folder, rate=50)
    try:
        url = viewer.live_map_url()
        with Browser(chromium_binary()) as browser:
            browser.open(url)
            settled(browser, lambda g: g["ended"] and len(g["vehicles"]) == 3 and g["tracks"], "the end of the scene")
            yield browser
    finally:
        code, _, stderr = viewer.finish()
        assert code == 130, stderr[-3000:]  # stopped with Ctrl-C, as a user does


TRAILS = """JSON.stringify((() => {
  const onScreen = (e, x, y) => { const p = new DOMPoint(x, y).matrixTransform(e.getScreenCTM()); return [p.x, p.y]; };
  const layer = document.getElementById('layer-trails');
  return {
    newest_s: (state.tracks.stamp_ns - state.tracks.trail_epoch_ns) / 1e9,
    bands: [...layer.querySelectorAll('polyline.trail')].map((e) => ({
      vehicle: e.parentNode.id.replace('trail-', ''), age_s: Number(e.dataset.ageS), colour: e.getAttribute('stroke'),
      points: e.getAttribute('points').split(' ').map((p) => onScreen(e, ...p.split(',').map(Number)))})),
    recorded: state.tracks.vehicles.map((v) => ({vehicle: v.id,
      points: v.trail.map((p) => ({t: p[2], at: onScreen(layer, p[0], -p[1])}))})),
  };
})())"""


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    f = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + f * ab)))


def test_trails_fade_with_age_and_are_gone_past_the_trail_time(at_the_end) -> None:
    browser = at_the_end
    trail_s = 30.0
    browser.evaluate(f"const t = document.getElementById('trail-length'); t.value = '{trail_s:g}'; "
                     "t.dispatchEvent(new Event('change'))")
    trails = json.loads(browser.evaluate(TRAILS))
    drawn = browser.pixels(ARTIFACTS / "live_map_view_trails.png").astype(float)
    browser.evaluate("document.getElementById('layer-trails').style.display = 'none'")
    bare = browser.pixels(ARTIFACTS / "live_map_view_no_trails.png").astype(float)
    browser.evaluate("document.getElementById('layer-trails').style.display = ''")
    assert json.loads(browser.evaluate(TRAILS)) == trails  # the same state in both screenshots

    # the opacity each band is drawn with, read from the pixels: drawn = bare + alpha (colour - bare), solved for
    # alpha where the trail's colour stands out from what is under it, the best of the 3x3 pixels about each point
    # (a 2 px line covers its centre pixel); the point where two bands join is left out
    map_box = json.loads(browser.evaluate("JSON.stringify(document.getElementById('map').getBoundingClientRect())"))
    on_map = lambda x, y: map_box["left"] + 2 <= x < map_box["right"] - 2 and map_box["top"] + 2 <= y < map_box["bottom"] - 2  # noqa: E731
    alpha_by_age: dict[float, list[float]] = {}
    for band in trails["bands"]:
        colour = rgb(band["colour"])
        for x, y in (p for p in band["points"][1:] if on_map(*p)):
            cx, cy = round(x), round(y)
            d, b = drawn[cy - 1:cy + 2, cx - 1:cx + 2], bare[cy - 1:cy + 2, cx - 1:cx + 2]
            contrast = colour - b
            usable = np.linalg.norm(contrast, axis=2) > 60
            if usable.any():
                alpha = np.sum((d - b) * contrast, axis=2)[usable] / np.sum(contrast * contrast, axis=2)[usable]
                alpha_by_age.setdefault(band["age_s"], []).append(float(alpha.max()))
    ages = sorted(alpha_by_age)
    medians = [float(np.median(alpha_by_age[a])) for a in ages]
    print("trail opacity by age:", dict(zip(ages, (round(m, 2) for m in medians))))
    assert ages[0] == 0 and ages[-1] == pytest.approx(0.9 * trail_s) and len(ages) == 10, ages
    # fading linearly over the trail time, a tenth a band: full strength new, a tenth in the oldest band
    assert medians == pytest.approx([1 - age / trail_s for age in ages], abs=0.1), medians

    # the recorded positions older than the trail time are not drawn: the pixels there are the bare map's
    segments = [(np.array(a), np.array(b)) for band in trails["bands"] for a, b in zip(band["points"], band["points"][1:])]
    old = [np.array(p["at"]) for v in trails["recorded"] for p in v["points"]
           if trails["newest_s"] - p["t"] > trail_s + 0.5 and on_map(*p["at"])]
    apart = [p for p in old if min(_segment_distance(p, a, b) for a, b in segments) > 6.0]
    assert len(apart) >= 20, len(apart)
    for x, y in apart:
        cx, cy = round(x), round(y)
        assert np.abs(drawn[cy - 1:cy + 2, cx - 1:cx + 2] - bare[cy - 1:cy + 2, cx - 1:cx + 2]).max() <= 3, (x, y)


def test_labels_stay_apart_when_a_vehicle_is_right_above_the_target(at_the_end) -> None:
    end = page_geometry(at_the_end)
    at_the_end.pixels(ARTIFACTS / "live_map_view_labels.png")
    vehicles = {v["id"]: v for v in end["vehicles"]}
    (track,) = end["tracks"]
    assert math.dist(vehicles["uav1"]["at"], track["at"]) < 6  # px: uav1 over the target
    labels = {label["for"]: label for label in end["labels"]}
    assert sorted(labels) == ["track-target", "vehicle-uav1", "vehicle-uav2", "vehicle-uav3"]
    assert all(labels[f"vehicle-{k}"]["text"] == k for k in vehicles) and labels["track-target"]["text"] == "target"
    assert_labels_apart(end)
    anchors = {f"vehicle-{k}": v["at"] for k, v in vehicles.items()} | {"track-target": track["at"]}
    for key, label in labels.items():  # each beside what it names
        box, (ax, ay) = label["box"], anchors[key]
        nearest = (min(max(ax, box["x"]), box["x"] + box["w"]), min(max(ay, box["y"]), box["y"] + box["h"]))
        assert math.dist(nearest, (ax, ay)) < 90, (key, box, (ax, ay))
