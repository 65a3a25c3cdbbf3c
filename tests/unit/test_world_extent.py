"""The world's extent: a generated city's rectangle, a real city's content with a margin, and who reads it."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import numpy as np
import pytest

from gcs.config import ScenarioError, TargetConfig
from gcs.config.world import build_world
from gcs.core.roads import RoadGraph
from gcs.core.world import FRAME_MARGIN_M, Buildings, World, content_bounds
from gcs.adapters.live_map.picture_geometry import world_geometry
from gcs.scenarios import load_scenario, parse_scenario
from sim_vehicles.truth.target import WhiteNoiseTarget, start_state, target_model

URBAN = load_scenario("wang2012_urban")


def test_content_bounds_are_the_footprints_roads_and_points_with_the_margin() -> None:
    buildings = Buildings.from_boxes([[-300.0, 50.0, -200.0, 120.0], [100.0, -80.0, 160.0, 10.0]], [20.0, 30.0])
    roads = RoadGraph.from_segments([[-250.0, 0.0]], [[400.0, 0.0]])
    assert content_bounds(buildings, roads, [[0.0, 300.0]]) == (-400.0, -180.0, 500.0, 400.0)
    assert content_bounds(buildings, None, margin_m=10.0) == (-310.0, -90.0, 170.0, 130.0)
    assert content_bounds(Buildings.empty(), None) is None
    assert FRAME_MARGIN_M == 100.0


def test_a_world_is_its_rectangle_unless_given_bounds() -> None:
    assert World.empty((500.0, 400.0)).bounds_m == (0.0, 0.0, 500.0, 400.0)
    framed = World(Buildings.empty(), World.empty().airspace, None, (1.0, 1.0), None, (-400.0, -180.0, 500.0, 400.0))
    assert framed.size_m == (900.0, 580.0)
    assert framed.inside([[-399.0, 0.0], [501.0, 0.0], [0.0, -181.0]]).tolist() == [True, False, False]
    with pytest.raises(ValueError, match="bounds_m"):
        World(Buildings.empty(), World.empty().airspace, None, (1.0, 1.0), None, (0.0, 0.0, -1.0, 5.0))


def _geojson_city(tmp_path: Path, boxes: list[tuple[float, float, float, float]]) -> Path:
    features = [{"type": "Feature", "properties": {"height": 25.0},
                 "geometry": {"type": "Polygon", "coordinates": [[[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]]}}
                for x0, y0, x1, y1 in boxes]
    path = tmp_path / "city.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "gcs_frame": "enu", "features": features}))
    return path


def test_a_geojson_city_is_framed_on_its_buildings_and_the_start_points(tmp_path: Path) -> None:
    _geojson_city(tmp_path, [(100.0, 100.0, 180.0, 160.0), (300.0, 300.0, 380.0, 380.0)])
    scenario = msgspec.structs.replace(URBAN, city=msgspec.structs.replace(URBAN.city, kind="geojson",
                                                                           geojson="city.geojson"))
    world = build_world(scenario, tmp_path)
    # the buildings reach from (100, 100) to (380, 380); the UAVs start as far as (1800, 1900)
    assert world.bounds_m == (0.0, 0.0, 1900.0, 2000.0)
    assert build_world(URBAN).bounds_m == (0.0, 0.0, 3000.0, 3000.0)  # a generated city: its rectangle
    scene = world_geometry(scenario, world)  # what the live map draws and frames
    assert scene["bounds_m"] == [0.0, 0.0, 1900.0, 2000.0] and scene["size_m"] == [1900.0, 2000.0]


def test_start_points_are_checked_against_a_rectangle_only_where_there_is_one(tmp_path: Path) -> None:
    text = (Path(__file__).parents[2] / "gcs" / "scenarios" / "wang2012_urban.toml").read_text()
    moved = text.replace("start_enu_m = [1200.0, 1200.0]", "start_enu_m = [-1200.0, 1200.0]")
    with pytest.raises(ScenarioError, match=r"\$.vehicles\[0\].start_enu_m: \(-1200.0, 1200.0\) is outside the city"):
        parse_scenario(moved)
    real = moved.replace('kind = "generated"', 'kind = "geojson"\ngeojson = "city.geojson"', 1)
    assert parse_scenario(real).vehicles[0].start_enu_m == (-1200.0, 1200.0)


def test_a_free_target_keeps_to_a_real_citys_frame(tmp_path: Path) -> None:
    """About the origin, as a real city lies: the target starts at negative coordinates and drives about them."""
    _geojson_city(tmp_path, [(-300.0, -300.0, -150.0, -150.0), (150.0, 150.0, 300.0, 300.0)])
    scenario = msgspec.structs.replace(
        URBAN, city=msgspec.structs.replace(URBAN.city, kind="geojson", geojson="city.geojson"),
        vehicles=[msgspec.structs.replace(v, start_enu_m=(0.0, 0.0)) for v in URBAN.vehicles],
        target=TargetConfig(start_enu_m=(-100.0, -50.0), start_velocity_mps=(-6.0, -6.0), max_speed_mps=15.0))
    world = build_world(scenario, tmp_path)
    assert world.bounds_m == (-400.0, -400.0, 400.0, 400.0)
    model = target_model(scenario, world)
    assert isinstance(model, WhiteNoiseTarget)
    rng = np.random.default_rng(4)
    state = start_state(model, scenario, rng)
    path = []
    for _ in range(600):
        state = model.step(state, 1.0, rng)
        path.append(state.position)
    path = np.array(path)
    assert world.inside(path).all() and not world.buildings.contains_xy(path).any()
    # it drives about the city, west and south of the origin too
    assert path[:, 0].min() < -200.0 and path[:, 1].min() < -200.0 and np.ptp(path, axis=0).min() > 300.0
