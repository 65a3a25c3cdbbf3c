"""Drawn roads held against the road graph: every drawn segment is one of the graph's, each of them drawn once.

The graph's segments are read from its directed edges here, not from the map's
code: a one-way segment is its only edge (ordered, tail to head), a two-way
segment the pair of edges ``e`` and ``reverse[e]`` (unordered).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from gcs.core.roads import RoadGraph

__all__ = ["graph_segments", "assert_lines_are_the_graph"]


def graph_segments(graph: RoadGraph) -> Counter:
    """The graph's drivable segments: ``(tail, head)`` node pairs for a one-way segment, ``frozenset`` for a two-way."""
    out: Counter = Counter()
    for e in range(len(graph)):
        tail, head, back = int(graph.tail[e]), int(graph.head[e]), int(graph.reverse[e])
        if back < 0:
            out[tail, head] += 1
        elif e < back:
            out[frozenset((tail, head))] += 1
    return out


def assert_lines_are_the_graph(lines: list[np.ndarray], one_way: list[bool], graph: RoadGraph,
                               tolerance_m: float) -> int:
    """Every vertex of ``lines`` ((k, 2) ENU metres each) is a node of ``graph`` within ``tolerance_m``; their
    consecutive pairs are the graph's segments, each once, a one-way line's in its driving sense. Returns the number
    of segments."""
    drawn: Counter = Counter()
    for line, oneway in zip(lines, one_way, strict=True):
        distance = np.linalg.norm(line[:, None, :] - graph.nodes[None, :, :], axis=2)
        nodes = distance.argmin(axis=1)
        worst = distance[np.arange(len(line)), nodes].max()
        assert worst <= tolerance_m, f"a vertex {worst:.4f} m from the graph's nearest node"
        for a, b in zip(nodes[:-1].tolist(), nodes[1:].tolist()):
            drawn[(a, b) if oneway else frozenset((a, b))] += 1
    expected = graph_segments(graph)
    missing, extra = list((expected - drawn).items())[:5], list((drawn - expected).items())[:5]
    assert drawn == expected, (f"{sum(drawn.values())} segments drawn, {sum(expected.values())} in the graph; "
                               f"missing {missing}, extra {extra}")
    return sum(drawn.values())
