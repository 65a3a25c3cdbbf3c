"""RoadGraph by hand: successors, branch probabilities, nearest edge, walking through nodes.

The figures compared with are worked out from the drawings in each test, not taken from the code.
"""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.roads import RoadGraph, walk

# A crossing at the origin: arms of 100 m to the west, east, south and north.
CROSS_A = [(-100.0, 0.0), (0.0, 0.0), (0.0, -100.0), (0.0, 0.0)]
CROSS_B = [(0.0, 0.0), (100.0, 0.0), (0.0, 0.0), (0.0, 100.0)]


def _edge(graph: RoadGraph, a, b) -> int:
    """The directed edge from point a to point b."""
    tail = graph.nodes[graph.tail]
    head = graph.nodes[graph.head]
    found = np.flatnonzero(np.all(np.isclose(tail, a), axis=1) & np.all(np.isclose(head, b), axis=1))
    assert found.size == 1, f"no single edge {a} -> {b}"
    return int(found[0])


def test_crossing_has_five_nodes_eight_directed_edges_and_no_u_turns() -> None:
    graph = RoadGraph.from_segments(CROSS_A, CROSS_B)
    assert graph.nodes.shape == (5, 2) and len(graph) == 8
    assert graph.total_length_m == pytest.approx(400.0)
    eastbound = _edge(graph, (-100.0, 0.0), (0.0, 0.0))
    onward = set(graph.successors[eastbound][graph.successors[eastbound] >= 0].tolist())
    assert onward == {_edge(graph, (0, 0), (100, 0)), _edge(graph, (0, 0), (0, 100)), _edge(graph, (0, 0), (0, -100))}
    # the end of the east arm is a dead end: the only way on is back
    out_east = _edge(graph, (0, 0), (100, 0))
    assert graph.successors[out_east][0] == graph.reverse[out_east] == _edge(graph, (100, 0), (0, 0))


def test_branch_probabilities_straight_on_and_turns() -> None:
    graph = RoadGraph.from_segments(CROSS_A, CROSS_B)
    table = graph.branch_probabilities(0.3)
    eastbound = _edge(graph, (-100.0, 0.0), (0.0, 0.0))
    by_edge = dict(zip(graph.successors[eastbound].tolist(), table[eastbound].tolist()))
    assert by_edge[_edge(graph, (0, 0), (100, 0))] == pytest.approx(0.7)  # straight on: 1 - 0.3
    assert by_edge[_edge(graph, (0, 0), (0, 100))] == pytest.approx(0.15)  # each turn: 0.3 / 2
    assert by_edge[_edge(graph, (0, 0), (0, -100))] == pytest.approx(0.15)
    np.testing.assert_allclose(table.sum(axis=1), 1.0)


def test_t_junction_from_its_stem_splits_evenly() -> None:
    # the stem comes up from the south and meets an east-west road: no way straight on
    graph = RoadGraph.from_segments([(0.0, -100.0), (-100.0, 0.0), (0.0, 0.0)], [(0.0, 0.0), (0.0, 0.0), (100.0, 0.0)])
    stem = _edge(graph, (0, -100), (0, 0))
    table = graph.branch_probabilities(0.3)
    valid = graph.successors[stem] >= 0
    assert valid.sum() == 2
    np.testing.assert_allclose(table[stem][valid], [0.5, 0.5])
    np.testing.assert_allclose(graph.turn_cos[stem][valid], [0.0, 0.0], atol=1e-12)


def test_one_way_segment_has_one_direction_and_close_ends_merge() -> None:
    graph = RoadGraph.from_segments([(0.0, 0.0), (50.2, 0.1)], [(50.0, 0.0), (100.0, 0.0)], one_way=[True, False],
                                    merge_m=0.5)
    assert len(graph.nodes) == 3 and len(graph) == 3  # the 0.2 m gap is one node; 1 + 2 directed edges
    first = _edge(graph, (0, 0), graph.nodes[graph.head[0]])
    assert graph.reverse[first] == -1


def test_snap_gives_the_nearest_point_of_the_nearest_edge() -> None:
    graph = RoadGraph.from_segments(CROSS_A, CROSS_B)
    points = np.array([[-40.0, 7.0], [3.0, 60.0], [130.0, 0.0], [500.0, 400.0]])
    edge, s, distance = graph.snap(points)
    # the far point is nearest to the east arm's end (100, 0): sqrt(400^2 + 400^2), not the north end (583 m)
    np.testing.assert_allclose(distance, [7.0, 3.0, 30.0, np.hypot(400.0, 400.0)])
    np.testing.assert_allclose(graph.position(edge, s), [[-40.0, 0.0], [0.0, 60.0], [100.0, 0.0], [100.0, 0.0]])


def test_walk_crosses_nodes_and_branches_by_the_table() -> None:
    graph = RoadGraph.from_segments(CROSS_A, CROSS_B)
    table = graph.branch_probabilities(0.5)
    eastbound = _edge(graph, (-100.0, 0.0), (0.0, 0.0))
    n = 20_000
    edge, s = walk(graph, table, np.full(n, eastbound), np.full(n, 90.0), np.full(n, 30.0), np.random.default_rng(1))
    np.testing.assert_allclose(s, 20.0)  # 10 m to the node, 20 m beyond it
    share = np.mean(edge == _edge(graph, (0, 0), (100, 0)))
    # binomial standard error sqrt(0.25 / 20000) = 0.0035: 0.5 within 5 of them
    assert share == pytest.approx(0.5, abs=0.02)
    # a walk past the dead end comes back on the reverse edge
    out_east = _edge(graph, (0, 0), (100, 0))
    back, s_back = walk(graph, table, np.array([out_east]), np.array([95.0]), np.array([15.0]), np.random.default_rng(2))
    assert back[0] == graph.reverse[out_east] and s_back[0] == pytest.approx(10.0)


def test_bad_segments_are_refused() -> None:
    with pytest.raises(ValueError, match="finite"):
        RoadGraph.from_segments([(0.0, np.nan)], [(1.0, 1.0)])
    with pytest.raises(ValueError, match="no road segment"):
        RoadGraph.from_segments([(0.0, 0.0)], [(0.1, 0.0)])
    with pytest.raises(ValueError, match="turn_probability"):
        RoadGraph.from_segments(CROSS_A, CROSS_B).branch_probabilities(1.5)
