"""build_world: the shipped scenario, GeoJSON cities in ENU and WGS84, errors naming the file."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import numpy as np
import pytest

from gcs.config import RestrictedAirspace as ZoneConfig
from gcs.config import Scenario, ScenarioError
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.core.world import World, generate_city
from gcs.scenarios import load_scenario

URBAN = load_scenario("wang2012_urban")

FOOTPRINTS = [
    [(100.0, 100.0), (180.0, 100.0), (180.0, 160.0), (100.0, 160.0)],
    [(300.0, 300.0), (360.0, 310.0), (340.0, 380.0), (320.0, 330.0), (290.0, 360.0)],
]
HEIGHTS = [40.0, 75.5]


def _with_city(scenario: Scenario, **changes: object) -> Scenario:
    return msgspec.structs.replace(scenario, city=msgspec.structs.replace(scenario.city, **changes))


def _write(path: Path, features_xy: list, frame: str | None, to_coordinates=None) -> None:
    features = []
    for ring, height in zip(features_xy, HEIGHTS):
        coordinates = [list(to_coordinates(p) if to_coordinates else p) for p in ring + ring[:1]]
        features.append({"type": "Feature", "properties": {"levels_m": height},
                         "geometry": {"type": "Polygon", "coordinates": [coordinates]}})
    document: dict = {"type": "FeatureCollection", "features": features}
    if frame is not None:
        document["gcs_frame"] = frame
    path.write_text(json.dumps(document))


def test_shipped_scenario_builds_the_wang2012_city() -> None:
    world = build_world(URBAN)
    assert isinstance(world, World)
    assert len(world.buildings) == 400
    assert world.size_m == (3000.0, 3000.0)
    city = URBAN.city
    assert world.streets is not None and world.streets.width_m == city.street_width_m
    assert len(world.airspace) == 0
    expected, _ = generate_city(np.random.default_rng(city.seed), city.size_m, city.buildings, city.street_width_m,
                                city.min_height_m, city.max_height_m)
    np.testing.assert_array_equal(world.buildings.edges, expected.edges)
    np.testing.assert_array_equal(world.buildings.heights, expected.heights)
    # The UAVs start above the roofs and can see straight down.
    for vehicle in URBAN.vehicles:
        assert vehicle.altitude_m > world.buildings.heights.max()
    # The target starts on a street crossing, so a UAV straight above sees it.
    start = URBAN.target.start_enu_m
    assert world.streets.on_street(start) and not world.buildings.contains_xy(start)
    assert world.line_of_sight([*start, 0.0], [*start, 200.0])


def test_enu_geojson_city_relative_to_base_dir(tmp_path: Path) -> None:
    _write(tmp_path / "city.geojson", FOOTPRINTS, "enu")
    scenario = _with_city(URBAN, kind="geojson", geojson="city.geojson", height_property="levels_m")
    world = build_world(scenario, base_dir=tmp_path)
    assert len(world.buildings) == 2 and world.streets is None
    np.testing.assert_array_equal(world.buildings.heights, HEIGHTS)
    np.testing.assert_array_equal(world.buildings.bbox[0], [100.0, 100.0, 180.0, 160.0])
    assert world.buildings.contains_xy([[140.0, 130.0], [330.0, 340.0], [320.0, 350.0]]).tolist() == [True, True, False]


def test_wgs84_geojson_city_is_converted_about_the_origin(tmp_path: Path) -> None:
    frame = LocalFrame(URBAN.origin.lat_deg, URBAN.origin.lon_deg, URBAN.origin.height_m)

    def lon_lat(p: tuple[float, float]) -> tuple[float, float]:
        lat, lon, _ = frame.to_geodetic([p[0], p[1], 0.0])
        return float(lon), float(lat)

    _write(tmp_path / "city.geojson", FOOTPRINTS, None, lon_lat)
    scenario = _with_city(URBAN, kind="geojson", geojson=str(tmp_path / "city.geojson"), height_property="levels_m")
    world = build_world(scenario)
    for got, want in zip(world.buildings.footprints, FOOTPRINTS):
        assert set(map(tuple, np.round(got, 2).tolist())) == set(want)


def test_geojson_errors_name_the_file(tmp_path: Path) -> None:
    scenario = _with_city(URBAN, kind="geojson", geojson="city.geojson", height_property="levels_m")
    path = tmp_path / "city.geojson"
    with pytest.raises(ScenarioError, match=f"{path}: cannot read GeoJSON city"):
        build_world(scenario, base_dir=tmp_path)
    path.write_text("{not json")
    with pytest.raises(ScenarioError, match=f"{path}: not valid JSON"):
        build_world(scenario, base_dir=tmp_path)
    _write(path, FOOTPRINTS, "enu")
    with pytest.raises(ScenarioError, match=f"{path}: feature 0: missing property 'height'"):
        build_world(_with_city(scenario, height_property="height"), base_dir=tmp_path)
    _write(path, FOOTPRINTS, None)  # metres, but no "gcs_frame": "enu"
    with pytest.raises(ScenarioError, match=f"{path}: .*gcs_frame"):
        build_world(scenario, base_dir=tmp_path)
    _write(path, FOOTPRINTS, "utm")
    with pytest.raises(ScenarioError, match="'gcs_frame' must be"):
        build_world(scenario, base_dir=tmp_path)


def test_empty_city_and_restricted_zones() -> None:
    zone = ZoneConfig(name="no_fly", polygon_enu_m=[(1000.0, 1000.0), (1200.0, 1000.0), (1200.0, 1200.0)],
                      floor_m=0.0, ceiling_m=400.0)
    scenario = msgspec.structs.replace(_with_city(URBAN, kind="empty"), restricted=[zone])
    world = build_world(scenario)
    assert len(world.buildings) == 0 and world.streets is None
    assert world.in_restricted([[1150.0, 1050.0, 200.0], [1050.0, 1150.0, 200.0], [1150.0, 1050.0, 450.0]]).tolist() \
        == [True, False, False]
    assert world.line_of_sight([0.0, 0.0, 0.0], [3000.0, 3000.0, 1.0])


def test_impossible_generated_city_is_a_scenario_error() -> None:
    with pytest.raises(ScenarioError, match="wang2012_urban: \\$.city: street_width_m"):
        build_world(_with_city(URBAN, size_m=(100.0, 100.0), street_width_m=200.0))


def test_world_empty() -> None:
    world = World.empty((500.0, 400.0))
    assert world.size_m == (500.0, 400.0)
    assert world.line_of_sight([0.0, 0.0, 0.0], [[10.0, 10.0, 10.0], [400.0, 0.0, 5.0]]).all()
    assert not world.in_restricted([0.0, 0.0, 0.0])
    assert world.visibility_map((0.0, 0.0), 100.0, 1000.0).visible([900.0, 0.0])
