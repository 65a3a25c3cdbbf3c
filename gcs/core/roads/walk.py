"""Driving a distance along the road graph: through nodes, branching at junctions, vectorised.

A vehicle on edge ``e`` at arc length ``s`` that drives ``d >= 0`` metres reaches
``s + d`` on the same edge when ``s + d <= l_e``; otherwise it enters a successor
``e'`` of ``e`` (drawn from the branch table ``T[e, :]``,
:meth:`gcs.core.roads.graph.RoadGraph.branch_probabilities`) with ``d`` reduced
by ``l_e - s`` and ``s = 0``, and so on. A negative distance (a vehicle driving
backwards, a negative speed) stops at the start of its edge: the trackers keep
speeds along the edge's direction non-negative in expectation, and a car that
turns round is one on the reverse edge.

:func:`walk` moves every particle of an array at once; the loop runs once per
node crossed by the particle that crosses the most, over the particles still
moving only.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.roads.graph import RoadGraph

__all__ = ["walk", "draw_successor"]

MAX_NODES_PER_WALK = 64
"""Nodes a single walk may cross; past them a particle stops at the end of the edge it reached."""


def draw_successor(graph: RoadGraph, table: NDArray[np.float64], edges: NDArray[np.intp],
                   rng: np.random.Generator) -> NDArray[np.intp]:
    """One successor of each edge (n,), drawn with the row probabilities of ``table`` (E, K)."""
    cumulative = np.cumsum(table[edges], axis=1)
    u = rng.random(len(edges)) * cumulative[:, -1]
    k = (u[:, None] >= cumulative).sum(axis=1)
    k = np.minimum(k, table.shape[1] - 1)
    successors: NDArray[np.intp] = graph.successors[edges, k]
    return successors


def walk(graph: RoadGraph, table: NDArray[np.float64], edge: NDArray[np.intp], s: NDArray[np.float64],
         distance: NDArray[np.float64], rng: np.random.Generator) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Each particle's edge and arc length after driving ``distance`` (n,) metres (module docstring).

    Returns new arrays; ``edge``, ``s`` and ``distance`` are not changed.
    """
    edge = np.array(edge, dtype=np.intp)
    s = np.maximum(np.asarray(s, dtype=np.float64) + distance, 0.0)
    over = np.flatnonzero(s > graph.length[edge])
    for _ in range(MAX_NODES_PER_WALK):
        if over.size == 0:
            break
        rest = s[over] - graph.length[edge[over]]
        edge[over] = draw_successor(graph, table, edge[over], rng)
        s[over] = rest
        over = over[rest > graph.length[edge[over]]]
    if over.size:
        s[over] = graph.length[edge[over]]
    return edge, s
