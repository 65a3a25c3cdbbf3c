"""The simulator's car on a road graph (RoadTarget): distances, turn choices, dead ends, the scenario's choice."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import numpy as np
import pytest

from gcs.config import CityConfig, TargetConfig
from gcs.config.world import build_world
from gcs.core.roads import RoadGraph
from gcs.scenarios import load_scenario
from sim_vehicles.truth.road_target import RoadTarget, RoadTargetState
from sim_vehicles.truth.target import StreetTarget, start_state, target_model

# A T-junction at C (0, 0): a street from W (-100, 0) to E (100, 0), and a stem down to S (0, -100).
T_JUNCTION = RoadGraph.from_segments([[-100.0, 0.0], [0.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [100.0, 0.0], [0.0, -100.0]])


def _edge(graph: RoadGraph, a: tuple[float, float], b: tuple[float, float]) -> int:
    tail, head = (int(np.argmin(np.hypot(*(graph.nodes - p).T))) for p in (a, b))
    (edge,) = np.flatnonzero((graph.tail == tail) & (graph.head == head))
    return int(edge)


def _on(graph: RoadGraph, car: RoadTarget, edge: int, s: float) -> RoadTargetState:
    """The car driving ``edge`` at ``s`` metres along it."""
    return RoadTargetState(graph.position(edge, s), graph.direction[edge] * car.speed_mps, 0.0, edge, s)


def test_a_step_drives_its_distance_through_the_junction() -> None:
    car = RoadTarget(T_JUNCTION, speed_mps=10.0, turn_probability=0.0)
    west_in = _edge(T_JUNCTION, (-100.0, 0.0), (0.0, 0.0))
    state = car.step(_on(T_JUNCTION, car, west_in, 95.0), 2.0, np.random.default_rng(0))
    # 20 m: 5 m to the junction, then straight on (no turns) 15 m along C -> E
    assert state.edge == _edge(T_JUNCTION, (0.0, 0.0), (100.0, 0.0)) and state.s_m == pytest.approx(15.0)
    np.testing.assert_allclose(state.position, [15.0, 0.0])
    np.testing.assert_allclose(state.velocity, [10.0, 0.0])
    assert state.elapsed_s == 2.0


@pytest.mark.parametrize(("start", "turn", "expected"), [
    # from the west: straight on with 1 - p, plus its share p / 2 of a uniform pick between straight and the stem
    (((-100.0, 0.0), (0.0, 0.0)), 0.3, {(100.0, 0.0): 0.7 + 0.15, (0.0, -100.0): 0.15}),
    # up the stem: nothing goes straight on, so either way is as likely
    (((0.0, -100.0), (0.0, 0.0)), 0.3, {(100.0, 0.0): 0.5, (-100.0, 0.0): 0.5}),
])
def test_turn_choices_at_a_junction(start, turn, expected) -> None:
    car = RoadTarget(T_JUNCTION, speed_mps=10.0, turn_probability=turn)
    edge = _edge(T_JUNCTION, *start)
    rng = np.random.default_rng(5)
    draws = 4000
    ends = [car.step(_on(T_JUNCTION, car, edge, 99.0), 0.5, rng).position for _ in range(draws)]
    for end, p in expected.items():
        direction = np.array(end) / 100.0
        share = np.mean([np.dot(position, direction) > 3.0 for position in ends])
        assert share == pytest.approx(p, abs=4.5 * np.sqrt(p * (1 - p) / draws)), end


def test_dead_ends_turn_back_and_a_one_way_road_that_ends_stops_the_car() -> None:
    car = RoadTarget(T_JUNCTION, speed_mps=10.0)
    east_out = _edge(T_JUNCTION, (0.0, 0.0), (100.0, 0.0))
    state = car.step(_on(T_JUNCTION, car, east_out, 95.0), 1.0, np.random.default_rng(0))
    assert state.edge == _edge(T_JUNCTION, (100.0, 0.0), (0.0, 0.0)) and state.s_m == pytest.approx(5.0)
    one_way = RoadGraph.from_segments([[0.0, 0.0]], [[50.0, 0.0]], one_way=[True])
    car = RoadTarget(one_way, speed_mps=10.0)
    state = car.step(_on(one_way, car, 0, 45.0), 1.0, np.random.default_rng(0))
    np.testing.assert_allclose(state.position, [50.0, 0.0])
    assert not state.velocity.any()
    later = car.step(state, 1.0, np.random.default_rng(0))
    np.testing.assert_allclose(later.position, [50.0, 0.0])
    assert later.elapsed_s == 2.0


def _roads_scenario(tmp_path: Path):
    """wang2012_urban with its generated city and a declared road: an L from (100, 100) via (500, 100) to (500, 400)."""
    (tmp_path / "roads.geojson").write_text(json.dumps({"type": "FeatureCollection", "gcs_frame": "enu", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
                                                          "coordinates": [[100, 100], [500, 100], [500, 400]]}}]}))
    base = load_scenario("wang2012_urban")
    return msgspec.structs.replace(base, city=msgspec.structs.replace(base.city, roads_geojson="roads.geojson"),
                                   target=TargetConfig(motion="streets", start_enu_m=(300.0, 120.0), street_speed_mps=12.0))


def test_the_scenario_chooses_the_car_by_its_roads(tmp_path: Path) -> None:
    scenario = _roads_scenario(tmp_path)
    world = build_world(scenario, tmp_path)
    car = target_model(scenario, world)
    # a city that declares its roads is driven on them, even a generated one with its own street grid
    assert isinstance(car, RoadTarget) and car.speed_mps == 12.0
    rng = np.random.default_rng(2)
    state = start_state(car, scenario, rng)
    np.testing.assert_allclose(state.position, [300.0, 100.0])  # the road point nearest (300, 120)
    path = [car.step(state, float(k), np.random.default_rng(2)).position for k in range(1, 80)]
    assert world.roads.snap(np.array(path))[2].max() < 1e-9
    again = start_state(car, scenario, np.random.default_rng(2))
    np.testing.assert_array_equal(again.velocity, state.velocity)  # the seed fixes the direction
    # a generated city without declared roads keeps its street-grid car
    generated = msgspec.structs.replace(scenario, city=CityConfig(size_m=(600.0, 600.0), buildings=16, seed=5))
    assert isinstance(target_model(generated, build_world(generated)), StreetTarget)
