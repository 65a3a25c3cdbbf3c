"""The roads ``/api/world`` serves on 127.0.0.1, held against the world's road graph.

The default 3 km city (``wang2012_urban``'s street grid) and the real city
(``helsinki_centre``, roads from OpenStreetMap with one-way streets): every
drawn segment is one of the graph's, each of them drawn once, a one-way one in
its driving sense, every vertex within 0.01 m of the graph's node; a city
without roads serves none.
"""

from __future__ import annotations

import json
import urllib.request

import numpy as np

from gcs.adapters.live_map.outputs import LiveMap
from gcs.config.world import build_world
from gcs.scenarios import load_scenario
from tests.road_segments import assert_lines_are_the_graph

TOLERANCE_M = 0.01


def _served_world(name: str) -> tuple[dict, object]:
    scenario = load_scenario(name)
    world = build_world(scenario)
    live = LiveMap.open(("127.0.0.1", 0), scenario, world)
    try:
        with urllib.request.urlopen(live.url + "api/world", timeout=10) as answer:
            return json.loads(answer.read()), world
    finally:
        live.close()


def test_the_default_city_serves_its_street_grid() -> None:
    served, world = _served_world("wang2012_urban")
    xs, ys = world.streets.xs, world.streets.ys
    roads = served["roads"]
    assert not any(r["one_way"] for r in roads)
    segments = assert_lines_are_the_graph([np.array(r["line"]) for r in roads], [False] * len(roads), world.roads,
                                          TOLERANCE_M)
    # every street between every two neighbouring crossings, counted from the grid itself
    assert segments == len(xs) * (len(ys) - 1) + len(ys) * (len(xs) - 1) == 840
    every = np.concatenate([r["line"] for r in roads])
    assert set(every[:, 0]) | set(every[:, 1]) <= set(xs) | set(ys)  # on the streets' centre lines, exactly
    assert len(roads) < 50  # a street is a line (the edge streets join at the corners), not 840 of them


def test_a_real_city_serves_its_roads_and_their_one_way_sense() -> None:
    served, world = _served_world("helsinki_centre")
    roads, graph = served["roads"], world.roads
    segments = assert_lines_are_the_graph([np.array(r["line"]) for r in roads], [r["one_way"] for r in roads], graph,
                                          TOLERANCE_M)
    one_way_edges = int((graph.reverse < 0).sum())
    assert segments == one_way_edges + (len(graph) - one_way_edges) // 2
    assert sum(len(r["line"]) - 1 for r in roads if r["one_way"]) == one_way_edges > 100
    west, south, east, north = served["bounds_m"]
    every = np.concatenate([r["line"] for r in roads])
    assert (every.min(axis=0) > [west, south]).all() and (every.max(axis=0) < [east, north]).all()


def test_a_city_without_roads_serves_none() -> None:
    served, world = _served_world("zuo2021_aoa")
    assert world.roads is None and served["roads"] == []
