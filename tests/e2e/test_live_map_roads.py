"""The roads on the live map, looked at in headless Chromium's screenshots: ``gcs replay --view`` of a still scene.

Two cities under "whole city": the default 3 km city (``wang2012_urban``, its street
grid) and the real one (``helsinki_centre``, from OpenStreetMap) with one road added
that runs through a building (a passage, as a declared road may). The known streets
are taken from the scenario's own data (the grid's centre line; Yrjönkatu from the
roads file), not from the page: along them the screenshot shows the legend's road
colour; inside every building (3 px in from its outline) it shows none, the passage
included, which is drawn on both sides of its building; the chevrons of the one-way
roads point the way the graph drives them; and the legend's checkbox takes every road
pixel away and gives them back. Screenshots are saved under ``tests/artifacts/``.
"""

from __future__ import annotations

import json
import math
import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from matplotlib.path import Path as Polygon
from PIL import Image, ImageDraw, ImageFilter

from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.scenarios import load_scenario
from tests.e2e.browser import ARTIFACTS, Browser, chromium_binary, page_geometry, rgb, settled
from tests.e2e.processes import script
from tests.e2e.test_live_map import _Command
from tests.recordings import still_recording

COLOUR_TOLERANCE = 30.0
"""A pixel is of a colour within this RGB distance: the road's colour is at least 45 from every building's shade and
100 from the ground's (a building is (s, s - 4, s - 12), s from 110 to 200), so antialiasing does not confuse them."""
STEP_M = 5.0
"""Samples along a known street, this far apart."""
INSET_PX = 3
"""How far inside a building's outline its pixels are looked at (the outline and its antialiasing excluded)."""

PAGE = """JSON.stringify((() => {
  const m = document.getElementById('map').getScreenCTM();
  const style = (selector, property) => { const e = document.querySelector(selector); return e && getComputedStyle(e)[property]; };
  const world = document.getElementById('layer-world'), roads = document.getElementById('layer-roads');
  const arrows = document.querySelector('#road-arrows path');
  return {ctm: [m.a, m.b, m.c, m.d, m.e, m.f], road: style('.road', 'stroke'), ground: style('rect.city', 'fill'),
          arrows: arrows ? arrows.getAttribute('d') : '', roads: document.body.dataset.roads,
          legend: style('.swatch.road', 'backgroundColor'),
          under_buildings: [...world.children].indexOf(roads) < [...world.children].indexOf(world.querySelector('.building')),
          under_tracks: world.compareDocumentPosition(document.getElementById('layer-track')) === Node.DOCUMENT_POSITION_FOLLOWING};
})())"""


def _screen(page: dict, xy: np.ndarray) -> np.ndarray:
    """ENU metres (k, 2) to screen pixels (k, 2), through the map's transform (SVG's y is -north)."""
    a, b, c, d, e, f = page["ctm"]
    x, y = xy[:, 0], -xy[:, 1]
    return np.column_stack([a * x + c * y + e, b * x + d * y + f])


def _along(line: np.ndarray, step_m: float = STEP_M) -> np.ndarray:
    """Points every ``step_m`` along a polyline (k, 2), its vertices included."""
    out = [line[:1]]
    for a, b in zip(line[:-1], line[1:]):
        n = max(1, math.ceil(np.linalg.norm(b - a) / step_m))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.concatenate(out)


def _near(pixels: np.ndarray, at: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """For each screen point, whether a pixel of its 3x3 has ``colour``."""
    out = []
    for x, y in np.round(at).astype(int):
        window = pixels[y - 1:y + 2, x - 1:x + 2].astype(float)
        out.append(bool((np.linalg.norm(window - colour, axis=2) < COLOUR_TOLERANCE).any()))
    return np.array(out)


def _clear(page: dict, geometry: dict, at: np.ndarray) -> np.ndarray:
    """Screen points away from what is drawn over the roads: the marks, their labels and the chevrons."""
    boxes = [v["body"] for v in geometry["vehicles"]] + [t["mark"] for t in geometry["truths"]] + \
        [label["box"] for label in geometry["labels"]]
    keep = np.ones(len(at), dtype=bool)
    for box in boxes:
        keep &= ~((at[:, 0] > box["x"] - 4) & (at[:, 0] < box["x"] + box["w"] + 4) &
                  (at[:, 1] > box["y"] - 4) & (at[:, 1] < box["y"] + box["h"] + 4))
    for centre in _screen(page, _chevrons(page)[0]):
        keep &= np.linalg.norm(at - centre, axis=1) > 8
    return keep


def _chevrons(page: dict) -> tuple[np.ndarray, np.ndarray]:
    """Centres (ENU m) and directions (ENU unit vectors) of the one-way chevrons, each ``M wing L tip L wing`` in SVG
    coordinates about its centre."""
    numbers = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", page["arrows"])]
    wing, tip, other = (np.array(numbers).reshape(-1, 3, 2)[:, k] * [1.0, -1.0] for k in range(3))
    base = (wing + other) / 2
    direction = tip - base
    return (tip + base) / 2, direction / np.linalg.norm(direction, axis=1, keepdims=True)


def _buildings(page: dict, footprints, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Screen pixels at least INSET_PX inside a building's outline, and those at least INSET_PX outside every one."""
    mask = Image.new("L", (shape[1], shape[0]), 0)
    draw = ImageDraw.Draw(mask)
    for footprint in footprints:
        draw.polygon([tuple(p) for p in _screen(page, np.asarray(footprint))], fill=255)
    size = 2 * INSET_PX + 1
    inside, outside = mask.filter(ImageFilter.MinFilter(size)), mask.filter(ImageFilter.MaxFilter(size))
    return np.asarray(inside) > 0, np.asarray(outside) == 0


def _look(browser: Browser, name: str) -> tuple[dict, dict, np.ndarray]:
    geometry = settled(browser)
    page = json.loads(browser.evaluate(PAGE))
    return page, geometry, browser.pixels(ARTIFACTS / name).astype(float)


def _check_the_roads(browser: Browser, world, known_street: list[np.ndarray], name: str) -> dict:
    """The checks both cities share (module docstring); the page as shown, for more."""
    settled(browser, lambda g: len(g["vehicles"]) == 3, "the vehicles")
    browser.evaluate("document.getElementById('city').click()")
    settled(browser, lambda g: g["look"] == "city", "the whole city")
    page, geometry, pixels = _look(browser, f"live_map_roads_{name}.png")
    road, ground = rgb(page["road"]), rgb(page["ground"])
    assert page["roads"] == "shown" and page["under_buildings"] and page["under_tracks"], page
    assert np.linalg.norm(rgb(page["legend"]) - road) < 1  # the legend's swatch is the roads' colour
    assert np.linalg.norm(road - ground) > 3 * COLOUR_TOLERANCE

    # along the known street: the road's colour wherever nothing is drawn over it
    at = _screen(page, np.concatenate([_along(line) for line in known_street]))
    at = at[_clear(page, geometry, at)]
    assert len(at) >= 40, len(at)
    on_street = _near(pixels, at, road)
    assert on_street.all(), at[~on_street][:10]

    # inside every building: no road pixel (the buildings are drawn over the roads)
    inside, outside = _buildings(page, world.buildings.footprints, pixels.shape[:2])
    assert inside.sum() > 10_000
    box = geometry["map"]
    on_map = np.zeros(pixels.shape[:2], dtype=bool)
    on_map[round(box["y"]):round(box["y"] + box["h"]), round(box["x"]):round(box["x"] + box["w"])] = True
    road_pixels = (np.linalg.norm(pixels - road, axis=2) < COLOUR_TOLERANCE) & on_map
    assert road_pixels.sum() > 5_000 and not (road_pixels & inside).any(), np.argwhere(road_pixels & inside)[:10]

    # the checkbox takes the roads away: the ground's colour along the street; and gives them back
    browser.evaluate("document.getElementById('show-roads').click()")
    browser.wait_for("document.body.dataset.roads === 'hidden'", 10, "the roads hidden")
    _, _, hidden = _look(browser, f"live_map_roads_{name}_hidden.png")
    assert not _near(hidden, at, road).any()
    assert not ((np.linalg.norm(hidden - road, axis=2) < COLOUR_TOLERANCE) & on_map).any()  # none left on the map
    assert _near(hidden, at, ground).all()
    browser.evaluate("document.getElementById('show-roads').click()")
    browser.wait_for("document.body.dataset.roads === 'shown'", 10, "the roads shown again")
    _, _, again = _look(browser, f"live_map_roads_{name}_again.png")
    assert _near(again, at, road).all()
    return {"page": page, "geometry": geometry, "pixels": pixels, "inside": inside, "outside": outside, "road": road}


def _seen(scenario, scenario_argument: str, world, known_street: list[np.ndarray], name: str, folder: Path) -> dict:
    """``gcs replay --view`` of a still scene in the city, looked at by :func:`_check_the_roads`; stopped by Ctrl-C."""
    recording = still_recording(folder / "still.mcap", scenario)
    viewer = _Command([script("gcs"), "replay", str(recording), "--view", "--scenario", scenario_argument,
                       "--http", "127.0.0.1:0", "--rate", "1"], folder / "viewer.log")
    try:
        with Browser(chromium_binary()) as browser:
            browser.open(viewer.live_map_url())
            seen = _check_the_roads(browser, world, known_street, name)
    finally:
        code, _, stderr = viewer.finish()
    assert code == 130, stderr[-3000:]  # stopped with Ctrl-C, as a user does
    return seen


def test_the_default_city_draws_its_street_grid_under_the_buildings(tmp_path: Path) -> None:
    scenario = load_scenario("wang2012_urban")
    world = build_world(scenario)
    xs, ys = world.streets.xs, world.streets.ys
    street = [np.array([[xs[7], ys[0]], [xs[7], ys[-1]]])]  # a north-south street across the city
    seen = _seen(scenario, "wang2012_urban", world, street, "grid", tmp_path)
    assert seen["page"]["arrows"] == ""  # no one-way street: no chevron


def _helsinki_with_a_passage(folder: Path) -> tuple[Path, np.ndarray, int]:
    """helsinki_centre beside a copy of its roads and one road more, east-west through the middle of a building (the
    largest by its bounding box that such a road crosses for 30 m without meeting another one); the passage (ENU) and
    the building's index."""
    shipped = resources.files("gcs.scenarios")
    scenario = load_scenario("helsinki_centre")
    world = build_world(scenario)
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    outlines = [Polygon(np.asarray(f)) for f in world.buildings.footprints]
    for index in np.argsort([-(o.get_extents().width * o.get_extents().height) for o in outlines]):
        box = outlines[index].get_extents()
        y = (box.y0 + box.y1) / 2
        passage = np.array([[box.x0 - 40.0, y], [box.x1 + 40.0, y]])
        points = _along(passage, 1.0)
        inside = [outline.contains_points(points) for outline in outlines]
        others = np.any([hit for k, hit in enumerate(inside) if k != index], axis=0)
        if inside[index].sum() >= 30 and not others.any():
            break
    else:
        pytest.fail("no building for a passage")
    roads = json.loads((shipped / "helsinki_centre_roads.geojson").read_text())
    lat, lon, _ = frame.to_geodetic(np.column_stack([passage, np.full(2, 0.0)]))
    roads["features"].append({"type": "Feature", "properties": {"oneway": "no", "name": "passage"},
                              "geometry": {"type": "LineString", "coordinates": [[lon[0], lat[0]], [lon[1], lat[1]]]}})
    (folder / "roads_with_passage.geojson").write_text(json.dumps(roads))
    buildings = "helsinki_centre_buildings.geojson"
    (folder / buildings).write_bytes((shipped / buildings).read_bytes())
    toml = (shipped / "helsinki_centre.toml").read_text().replace('"helsinki_centre_roads.geojson"',
                                                                   '"roads_with_passage.geojson"')
    toml = toml.replace('name = "helsinki_centre"', 'name = "helsinki_passage"')
    path = folder / "helsinki_passage.toml"
    path.write_text(toml)
    return path, passage, int(index)


def test_a_real_city_draws_its_roads_under_the_buildings_with_their_one_way_sense(tmp_path: Path) -> None:
    path, passage, building = _helsinki_with_a_passage(tmp_path)
    scenario = load_scenario(path)
    world = build_world(scenario, tmp_path)
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    roads = json.loads((tmp_path / "roads_with_passage.geojson").read_text())["features"]
    yrjonkatu = [f for f in roads if f["properties"].get("name") == "Yrjönkatu"]  # a two-way street, 423 m
    assert yrjonkatu and all(f["properties"]["oneway"] == "no" for f in yrjonkatu)
    known = [f["geometry"]["coordinates"] for f in yrjonkatu]
    street = [frame.to_enu(np.array(c)[:, 1], np.array(c)[:, 0], np.full(len(c), scenario.origin.height_m))[:, :2]
              for c in known]
    seen = _seen(scenario, str(path), world, street, "real_city", tmp_path)
    page, pixels, road = seen["page"], seen["pixels"], seen["road"]

    # the passage: the road's colour on both sides of its building, the building's inside it
    at = _screen(page, _along(passage, 1.0))
    rows, columns = np.round(at[:, 1]).astype(int), np.round(at[:, 0]).astype(int)
    inside, outside = seen["inside"][rows, columns], seen["outside"][rows, columns] & _clear(page, seen["geometry"], at)
    assert outside.sum() >= 20 and _near(pixels, at[outside], road).all()
    assert inside.sum() >= 5 and not _near(pixels, at[inside], road).any()
    assert Polygon(np.asarray(world.buildings.footprints[building])).contains_points(_along(passage, 1.0)).sum() >= 30

    # every chevron lies on a one-way road of the graph and points the way it is driven
    centres, directions = _chevrons(page)
    assert len(centres) >= 10, len(centres)
    graph = world.roads
    one_way = np.flatnonzero(graph.reverse < 0)
    a, d, length = graph.nodes[graph.tail[one_way]], graph.direction[one_way], graph.length[one_way]
    for centre, direction in zip(centres, directions):
        s = np.clip(np.einsum("ij,ij->i", centre - a, d), 0.0, length)
        distance = np.linalg.norm(a + s[:, None] * d - centre, axis=1)
        on = distance < distance.min() + 0.05
        assert distance.min() < 0.05 and (d[on] @ direction).max() > 0.999, (centre, distance.min())
