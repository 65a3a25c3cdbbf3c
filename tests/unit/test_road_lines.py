"""The roads as the maps draw them: the graph's segments joined into polylines, held against drawings made by hand."""

from __future__ import annotations

import numpy as np

from gcs.adapters.live_map.road_lines import road_lines
from gcs.core.roads import RoadGraph
from gcs.core.roads.sources import roads_from_street_grid
from gcs.core.world import StreetGrid
from tests.road_segments import assert_lines_are_the_graph


def _graph(segments: list[tuple[tuple[float, float], tuple[float, float], bool]]) -> RoadGraph:
    a, b, one_way = zip(*segments)
    return RoadGraph.from_segments(a, b, one_way)


def _drawn(graph: RoadGraph) -> set[tuple]:
    """Each polyline as a tuple of points with its kind; a two-way one in either order."""
    out = set()
    for road in road_lines(graph):
        points = tuple(tuple(p) for p in road["line"])
        out.add((min(points, points[::-1]) if not road["one_way"] else points, road["one_way"]))
    return out


def _two_way(*points) -> tuple:
    points = tuple(points)
    return min(points, points[::-1]), False


def test_streets_run_straight_through_crossings_and_round_the_bends_of_one_road() -> None:
    graph = _graph([
        ((0.0, 0.0), (100.0, 0.0), False), ((100.0, 0.0), (200.0, 0.0), False),  # west-east through a crossing
        ((100.0, -100.0), (100.0, 0.0), False), ((100.0, 0.0), (100.0, 100.0), False),  # south-north through it
        ((200.0, 0.0), (250.0, 50.0), False), ((250.0, 50.0), (250.0, 150.0), False),  # the west-east road bends north
        ((100.0, 100.0), (160.0, 100.0), False),  # a side street off the north end: a corner, two segments meet
    ])
    assert _drawn(graph) == {
        _two_way((0.0, 0.0), (100.0, 0.0), (200.0, 0.0), (250.0, 50.0), (250.0, 150.0)),
        _two_way((100.0, -100.0), (100.0, 0.0), (100.0, 100.0), (160.0, 100.0)),
    }


def test_a_turn_at_a_junction_ends_the_line_and_a_one_way_road_runs_as_it_is_driven() -> None:
    graph = _graph([
        ((0.0, 0.0), (100.0, 0.0), False), ((100.0, 0.0), (100.0, 100.0), False),  # a T: the stem turns north...
        ((100.0, 0.0), (100.0, -100.0), False),  # ...or south: the north-south road runs straight through
        ((300.0, 0.0), (200.0, 0.0), True), ((200.0, 0.0), (200.0, 100.0), True),  # one-way west, then north
        ((200.0, 100.0), (200.0, 150.0), False),  # a two-way road goes on from its end: another kind, another line
        ((0.0, 300.0), (100.0, 300.0), True), ((100.0, 300.0), (0.0, 300.0), True),  # one way each way, one pair
    ])
    assert _drawn(graph) == {
        _two_way((0.0, 0.0), (100.0, 0.0)),
        _two_way((100.0, 100.0), (100.0, 0.0), (100.0, -100.0)),
        (((300.0, 0.0), (200.0, 0.0), (200.0, 100.0)), True),
        _two_way((200.0, 100.0), (200.0, 150.0)),
        (((0.0, 300.0), (100.0, 300.0)), True),
        (((100.0, 300.0), (0.0, 300.0)), True),
    }


def test_a_ring_road_is_one_closed_line() -> None:
    corners = [(0.0, 0.0), (80.0, 0.0), (80.0, 60.0), (0.0, 60.0)]
    graph = _graph([(corners[i], corners[(i + 1) % 4], False) for i in range(4)])
    (road,) = road_lines(graph)
    assert road["line"][0] == road["line"][-1] and len(road["line"]) == 5
    assert {tuple(p) for p in road["line"]} == set(corners)


def test_vertices_are_the_graph_nodes_to_the_centimetre() -> None:
    rng = np.random.default_rng(7)
    a = rng.uniform(-500.0, 500.0, (40, 2))
    b = a + rng.uniform(-80.0, 80.0, (40, 2))
    graph = RoadGraph.from_segments(a, b, rng.uniform(size=40) < 0.3)
    lines = road_lines(graph)
    count = assert_lines_are_the_graph([np.array(r["line"]) for r in lines], [r["one_way"] for r in lines], graph,
                                       tolerance_m=0.005 * np.sqrt(2) + 1e-9)
    assert count == 40


def test_a_street_grid_is_one_line_a_street_but_the_edge_streets_join_at_the_corners() -> None:
    xs, ys = np.arange(0.0, 1001.0, 250.0), np.arange(0.0, 601.0, 200.0)  # 5 north-south and 4 east-west streets
    graph = roads_from_street_grid(StreetGrid(xs=xs, ys=ys, width_m=20.0, size_m=(1000.0, 600.0)))
    lines = road_lines(graph)
    # the four edge streets meet at corners where nothing else does: one ring; the 3 + 2 inner streets, a line each
    assert len(lines) == 1 + (len(xs) - 2) + (len(ys) - 2)
    ring = max(lines, key=lambda r: len(r["line"]))
    assert len(ring["line"]) == 2 * (len(xs) - 1) + 2 * (len(ys) - 1) + 1
    assert assert_lines_are_the_graph([np.array(r["line"]) for r in lines], [False] * len(lines), graph, 0.0) == \
        len(xs) * (len(ys) - 1) + len(ys) * (len(xs) - 1)
