"""A road graph as the maps draw it: each drivable segment once, joined into polylines.

:class:`~gcs.core.roads.RoadGraph` holds directed straight edges, two per
two-way segment and one per one-way segment. A map draws each **segment**
once: a two-way segment by its edge ``e`` with ``e < reverse[e]``, a one-way
segment by its only edge, in its driving direction.

Segments of the same kind (two-way, or one-way driven on in the same sense) are
joined into **polylines**, so that a street is one line and the drawing is a few
hundred polylines rather than thousands of segments. A polyline that reaches a
node goes on into a segment not yet drawn

* when exactly two segments meet there (a shape point of a bent road), whatever the angle, or
* straight on through a junction: the segment whose direction makes the smallest
  angle with the one it arrives along, if its cosine exceeds
  :data:`~gcs.core.roads.graph.STRAIGHT_COS` (the trackers' "straight on", about 26 degrees).

Every segment is in exactly one polyline, so the polylines' consecutive vertex
pairs are the graph's segments. A generated city's grid of ``n_x`` north-south
and ``n_y`` east-west streets becomes ``n_x + n_y`` polylines.
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from gcs.core.roads.graph import STRAIGHT_COS, RoadGraph

__all__ = ["ROAD_DECIMALS", "road_lines", "road_segments"]

ROAD_DECIMALS = 2
"""Road vertices are rounded to the centimetre (the buildings to the decimetre): a junction drawn where the graph has
it, to within 0.005 m, for the few kilobytes more that grid coordinates do not even cost."""


def road_segments(graph: RoadGraph) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each drivable segment once: ``tail (S,)``, ``head (S,)`` node indices and ``one_way (S,)``.

    A two-way segment is its edge ``e < reverse[e]``; a one-way segment its only edge, tail to head in its
    driving direction.
    """
    edges = np.arange(len(graph))
    keep = (graph.reverse < 0) | (graph.reverse > edges)
    return graph.tail[keep], graph.head[keep], graph.reverse[keep] < 0


def road_lines(graph: RoadGraph) -> list[dict]:
    """The graph's segments joined into polylines (module docstring).

    Returns
    -------
    list of dict
        ``{"line": [[x, y], ...], "one_way": bool}``, ENU metres rounded to :data:`ROAD_DECIMALS`; a one-way
        polyline runs in its driving direction.
    """
    tail, head, one_way = (a.tolist() for a in road_segments(graph))
    xy = graph.nodes.tolist()
    at_node: dict[int, list[int]] = defaultdict(list)
    for s, (a, b) in enumerate(zip(tail, head)):
        at_node[a].append(s)
        at_node[b].append(s)
    drawn = [False] * len(tail)

    def onward(node: int, came_from: int, forward: bool, kind: bool) -> tuple[int, int] | None:
        """The segment of kind ``kind`` (one-way or not) that a polyline at ``node``, arriving from node
        ``came_from``, goes on along, and that segment's far node; None where the polyline ends."""
        (x0, y0), (x1, y1) = xy[came_from], xy[node]
        arriving = math.hypot(x1 - x0, y1 - y0)
        best, best_cos = None, -math.inf
        for s in at_node[node]:
            if drawn[s] or one_way[s] != kind or (kind and (tail[s] if forward else head[s]) != node):
                continue  # drawn already, another kind, or a one-way segment driven the other way
            far = head[s] if tail[s] == node else tail[s]
            if far == came_from:
                continue  # back the way it came (two one-way segments between the same two nodes)
            x2, y2 = xy[far]
            cos = ((x1 - x0) * (x2 - x1) + (y1 - y0) * (y2 - y1)) / (arriving * math.hypot(x2 - x1, y2 - y1))
            if cos > best_cos:
                best, best_cos = (s, far), cos
        if best is None or (len(at_node[node]) != 2 and best_cos <= STRAIGHT_COS):
            return None
        return best

    lines = []
    for first, kind in enumerate(one_way):
        if drawn[first]:
            continue
        drawn[first] = True
        chain = [tail[first], head[first]]
        for forward in (True, False):  # on from the head, then back from the tail
            while (step := onward(chain[-1], chain[-2], forward, kind)) is not None:
                drawn[step[0]] = True
                chain.append(step[1])
            chain.reverse()
        # reversed twice: the chain runs as its first segment does, tail to head (a one-way road's driving sense)
        lines.append({"line": [[round(xy[n][0], ROAD_DECIMALS), round(xy[n][1], ROAD_DECIMALS)] for n in chain],
                      "one_way": kind})
    return lines
