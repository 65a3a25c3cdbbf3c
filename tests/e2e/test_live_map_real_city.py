"""A real city on the live map: ``gcs replay --view`` of a short scene in ``helsinki_centre``, in headless Chromium.

The city (from OpenStreetMap) lies about the scenario's origin, mostly at negative
coordinates. The page must draw its extent where its buildings are and show all of
them, and nothing much more, under "whole city": the extent is the buildings, roads
and start points with the 100 m margin (``gcs.core.world.extent``); its roads are
drawn where the graph has them, inside the extent.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from tests.e2e.browser import ARTIFACTS, Browser, chromium_binary, settled
from tests.e2e.test_live_map import _Command
from tests.e2e.processes import script
from tests.recordings import still_recording

SCENARIO_NAME = "helsinki_centre"
SCENARIO = load_scenario(SCENARIO_NAME)
WORLD = build_world(SCENARIO)
CITY_STATE = """JSON.stringify((() => {
  const rect = document.querySelector('#layer-world rect.city');
  const box = rect.getBBox();
  const roads = document.querySelector('#layer-roads .road').getBBox();
  return {rect: [box.x, -(box.y + box.height), box.x + box.width, -box.y],
          roads: [roads.x, -(roads.y + roads.height), roads.x + roads.width, -roads.y],
          buildings: Number(document.getElementById('layer-world').dataset.buildings)};
})())"""


def test_whole_city_shows_the_real_city_where_its_buildings_are(tmp_path: Path) -> None:
    recording = still_recording(tmp_path / "helsinki.mcap", SCENARIO)  # the UAVs hold their start points
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
    # the roads are drawn where the graph has them, inside the extent and on screen
    low, high = WORLD.roads.nodes.min(axis=0), WORLD.roads.nodes.max(axis=0)
    assert drawn["roads"] == pytest.approx([low[0], low[1], high[0], high[1]], abs=0.01)
    assert west < low[0] and south < low[1] and high[0] < east and high[1] < north
    # "whole city" shows all of it, and not a 3 km square from the origin: the page's aspect may widen one side
    shown = city["shown"]
    assert shown["west"] <= west and shown["south"] <= south and shown["east"] >= east and shown["north"] >= north
    width, depth = east - west, north - south
    assert min((shown["east"] - shown["west"]) / width, (shown["north"] - shown["south"]) / depth) < 1.2
