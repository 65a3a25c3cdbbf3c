"""A real city on the live map: ``gcs replay --view`` of a short scene in ``helsinki_centre``, in headless Chromium.

The city (from OpenStreetMap) lies about the scenario's origin, mostly at negative
coordinates. The page must draw its extent where its buildings are and show all of
them, and nothing much more, under "whole city": the extent is the buildings, roads
and start points with the 100 m margin (``gcs.core.world.extent``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gcs.adapters.recording import Recorder
from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key, truth_key
from protocols.messages import NavReport, TargetTruth
from protocols.sensor_report import SensorReport
from tests.e2e.browser import ARTIFACTS, Browser, chromium_binary, settled
from tests.e2e.test_live_map import _Command
from tests.e2e.processes import script

SCENARIO_NAME = "helsinki_centre"
SCENARIO = load_scenario(SCENARIO_NAME)
WORLD = build_world(SCENARIO)
NS = 1_000_000_000
EPOCH_NS = 1_700_000_000 * NS
STEPS = 20

CITY_STATE = """JSON.stringify((() => {
  const rect = document.querySelector('#layer-world rect.city');
  const box = rect.getBBox();
  return {rect: [box.x, -(box.y + box.height), box.x + box.width, -box.y],
          buildings: Number(document.getElementById('layer-world').dataset.buildings)};
})())"""


def _scene(path: Path) -> None:
    """The UAVs hold their start points and the car waits at its start: the scene is about the city, not the flight."""
    with Recorder(path) as recorder:
        for vehicle in SCENARIO.vehicles:
            recorder.write_liveliness(alive_key(vehicle.id), True, EPOCH_NS - NS // 2)
        for k in range(STEPS):
            stamp = EPOCH_NS + k * NS
            for slot, vehicle in enumerate(SCENARIO.vehicles):
                x, y = vehicle.start_enu_m
                report = SensorReport(vehicle_id=vehicle.id, seq=k + 1, stamp_ns=stamp,
                                      vehicle_position_enu_m=(x, y, vehicle.altitude_m), detections=())
                nav = NavReport(vehicle_id=vehicle.id, seq=k + 1, stamp_ns=stamp, heading_rad=0.0,
                                velocity_enu_mps=(vehicle.speed_mps, 0.0, 0.0))
                recorder.write(report_key(vehicle.id), *encode(report), stamp + slot * 10_000_000)
                recorder.write(nav_key(vehicle.id), *encode(nav), stamp + slot * 10_000_000 + 1)
            truth = TargetTruth(target_id=SCENARIO.target.id, seq=k + 1, stamp_ns=stamp,
                                position_enu_m=SCENARIO.target.start_enu_m, velocity_enu_mps=(0.0, 0.0))
            recorder.write(truth_key(SCENARIO.target.id), *encode(truth), stamp + 50_000_000)


def test_whole_city_shows_the_real_city_where_its_buildings_are(tmp_path: Path) -> None:
    recording = tmp_path / "helsinki.mcap"
    _scene(recording)
    viewer = _Command([script("gcs"), "replay", str(recording), "--view", "--scenario", SCENARIO_NAME,
                       "--http", "127.0.0.1:0", "--rate", "1"], tmp_path / "viewer.log")
    west, south, east, north = WORLD.bounds_m
    try:
        with Browser(chromium_binary()) as browser:
            browser.open(viewer.live_map_url())
            settled(browser, lambda g: len(g["vehicles"]) == len(SCENARIO.vehicles), "the vehicles")
            browser.evaluate("document.getElementById('city').click()")
            city = settled(browser, lambda g: g["look"] == "city", "the whole city")
            browser.pixels(ARTIFACTS / "live_map_real_city.png")
            drawn = browser.evaluate(CITY_STATE)
    finally:
        code, _, stderr = viewer.finish()
    assert code == 130 and "Traceback" not in stderr, stderr[-3000:]  # stopped by Ctrl-C (gcs.cli_errors)
    drawn = json.loads(drawn)
    # the city's extent is drawn where the buildings are: west and south of the origin too
    assert drawn["rect"] == pytest.approx([west, south, east, north], abs=0.11)
    assert drawn["buildings"] == len(WORLD.buildings)
    # "whole city" shows all of it, and not a 3 km square from the origin: the page's aspect may widen one side
    shown = city["shown"]
    assert shown["west"] <= west and shown["south"] <= south and shown["east"] >= east and shown["north"] >= north
    width, depth = east - west, north - south
    assert min((shown["east"] - shown["west"]) / width, (shown["north"] - shown["south"]) / depth) < 1.2
