"""Road graphs of the generated street grid and of GeoJSON, and the world that carries them."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import numpy as np
import pytest

from gcs.config import ScenarioError
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.core.roads import roads_from_geojson, roads_from_street_grid
from gcs.core.world import World, generate_city
from gcs.scenarios import load_scenario
from sim_vehicles.truth.target import StreetTarget


def test_street_grid_graph_holds_every_street_and_the_cars_path() -> None:
    _, grid = generate_city(np.random.default_rng(7), size_m=(1200.0, 900.0), buildings=60, street_width_m=20.0)
    graph = roads_from_street_grid(grid)
    nx, ny = len(grid.xs), len(grid.ys)
    assert len(graph.nodes) == nx * ny
    # every north-south street runs the city's depth and every east-west one its width
    assert graph.total_length_m == pytest.approx(nx * 900.0 + ny * 1200.0)
    car = StreetTarget(grid.xs, grid.ys, speed_mps=13.0, turn_probability=0.6)
    rng = np.random.default_rng(3)
    state = car.start(np.array([600.0, 450.0]), rng)
    path = [state.position]
    for _ in range(600):  # 0.5 s steps, 3.9 km: many turns and the city's edges
        state = car.step(state, 0.5, rng)
        path.append(state.position)
    path = np.array(path)
    # every position and every midpoint between consecutive positions (the car moves <= 6.5 m a step, less than a
    # block, so a step that turns has its midpoint on one of the two streets) lies on an edge of the graph
    midpoints = 0.5 * (path[1:] + path[:-1])
    _, _, distance = graph.snap(np.concatenate([path, midpoints]))
    corner = np.hypot(*(path[1:] - path[:-1]).T) < 13.0 * 0.5 - 1e-6  # steps that turned cut the corner
    assert distance[: len(path)].max() < 1e-9
    assert distance[len(path):][~corner].max() < 1e-9
    assert distance[len(path):][corner].max() < 13.0 * 0.5 / 2  # a cut corner stays within half a step


def _collection(*features: dict, frame: str | None = "enu") -> dict:
    document: dict = {"type": "FeatureCollection", "features": list(features)}
    if frame is not None:
        document["gcs_frame"] = frame
    return document


def _line(coordinates, **properties) -> dict:
    return {"type": "Feature", "properties": properties, "geometry": {"type": "LineString", "coordinates": coordinates}}


def test_geojson_lines_meet_at_shared_vertices() -> None:
    document = _collection(
        _line([[0, 0], [100, 0], [200, 0]]),
        _line([[100, 0], [100, 150]], oneway="yes"),
        {"type": "Feature", "properties": {"oneway": "-1"},
         "geometry": {"type": "MultiLineString", "coordinates": [[[200, 0], [200, 80]], [[0, 0], [0, -50]]]}},
    )
    graph = roads_from_geojson(document)
    assert len(graph.nodes) == 6  # (0,0) (100,0) (200,0) (100,150) (200,80) (0,-50)
    assert len(graph) == 2 * 2 + 1 + 2  # two two-way segments, three one-way ones
    assert graph.total_length_m == pytest.approx(200 + 150 + 80 + 50)
    heads = {tuple(graph.nodes[graph.head[e]]) for e in range(len(graph)) if graph.reverse[e] < 0}
    assert heads == {(100.0, 150.0), (200.0, 0.0), (0.0, 0.0)}  # "-1" drives against the drawing


@pytest.mark.parametrize(("document", "message"), [
    ({"type": "Feature"}, "FeatureCollection"),
    (_collection({"type": "Feature", "geometry": {"type": "Point", "coordinates": [0, 0]}}),
     r"feature 0: geometry type 'Point' is not supported \(LineString or MultiLineString\)"),
    (_collection(_line([[0, 0], [10, 0]]), _line([[0, 0]])), "feature 1: a line needs at least 2 points"),
    (_collection(_line([[0, 0], ["a", 0]])), "feature 0: coordinates must be"),
    (_collection(_line([[0, 0], [10, 0]], oneway="sometimes")), "feature 0: property 'oneway' must be"),
    (_collection({"type": "Feature", "geometry": {"type": "MultiLineString", "coordinates": [[[0, 0], [5, 5]],
                                                                                            [[1, 1]]]}}),
     "feature 0 line 1: a line needs at least 2 points"),
])
def test_bad_geojson_roads_name_the_feature_and_key(document: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        roads_from_geojson(document)


def _scenario_with_roads(tmp_path: Path, document: dict, **city: object):
    (tmp_path / "roads.geojson").write_text(json.dumps(document))
    urban = load_scenario("wang2012_urban")
    return msgspec.structs.replace(urban, city=msgspec.structs.replace(urban.city, roads_geojson="roads.geojson", **city))


def test_scenario_roads_in_wgs84_are_converted_about_the_origin(tmp_path: Path) -> None:
    scenario = _scenario_with_roads(tmp_path, {}, kind="empty")
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    ends_enu = np.array([[0.0, 0.0], [300.0, 400.0]])
    lat, lon, _ = frame.to_geodetic(np.column_stack([ends_enu, np.zeros(2)]))
    document = _collection(_line([[float(lon[0]), float(lat[0])], [float(lon[1]), float(lat[1])]]), frame=None)
    scenario = _scenario_with_roads(tmp_path, document, kind="empty")
    world = build_world(scenario, base_dir=tmp_path)
    assert world.roads is not None and world.roads.total_length_m == pytest.approx(500.0, abs=0.01)


def test_world_roads_follow_the_city() -> None:
    world = build_world(load_scenario("downtown_dense"))
    assert world.roads is not None
    assert len(world.roads.nodes) == len(world.streets.xs) * len(world.streets.ys)
    assert World.empty().roads is None
    empty = msgspec.structs.replace(load_scenario("wang2012_urban"), city=msgspec.structs.replace(
        load_scenario("wang2012_urban").city, kind="empty"))
    assert build_world(empty).roads is None


def test_bad_roads_file_is_a_scenario_error_naming_file_and_key(tmp_path: Path) -> None:
    scenario = _scenario_with_roads(tmp_path, _collection(_line([[0, 0], [10, 0]], oneway=[1])))
    with pytest.raises(ScenarioError, match=r"roads.geojson: \$.city.roads_geojson: feature 0: property 'oneway'"):
        build_world(scenario, base_dir=tmp_path)
    (tmp_path / "roads.geojson").write_text("{not json")
    with pytest.raises(ScenarioError, match="roads.geojson: not valid JSON"):
        build_world(scenario, base_dir=tmp_path)
