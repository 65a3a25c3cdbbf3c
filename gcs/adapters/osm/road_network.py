"""The drivable road network of an OSM extract: which ways a car may drive, cut to a box, junction to junction.

**Drivable** (:func:`is_drivable`): a way whose ``highway`` is one of
:data:`DRIVABLE_HIGHWAYS`, the public roads a car may use (the OSM wiki's
Key:highway "Roads" and "Link roads", and ``living_street``; the values that
osmnx's ``drive`` network keeps in practice); not an area (``area=yes``, a
square drawn as a closed way); and not closed to cars: the most specific of
``motorcar``, ``motor_vehicle``, ``vehicle``, ``access`` that is present must not
be ``no`` or ``private``. Left out on purpose: ``service`` (driveways, car-park
aisles), ``track``, ``road`` (unknown class), ``busway``, footways, cycleways,
paths, steps and pedestrian streets.

**One-way** (:func:`oneway_direction`): ``oneway=yes|true|1`` drives in the
way's drawing order, ``oneway=-1|reverse`` against it; without a ``oneway`` tag
a roundabout (``junction=roundabout|circular``) and a motorway are one-way, as
OSM implies; anything else (``no``, ``reversible``, ``alternating``) is two-way.

**The network** (:func:`drive_network`):

1. each drivable way, reversed if it is one-way against its drawing, is cut where
   a node is missing from the extract and to the box (:mod:`.clipping`: a way that
   crosses the box's edge ends on it);
2. the pieces are merged into **edges from junction to junction**: a node ends an
   edge when it is not shared by exactly two segments, or where a one-way and a
   two-way road meet, or two one-way roads that do not continue each other; a
   closed loop with no junction is cut at its lowest node;
3. only the largest **strongly connected** part is kept (one arc per one-way
   edge, two per two-way edge; Tarjan's components via SciPy): from every kept
   junction a car can reach every other, so a simulated car never gets stuck at
   the end of a one-way street that leaves the box.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from gcs.adapters.osm.clipping import Box, Point, clipped_runs
from gcs.adapters.osm.reading import Way

__all__ = ["DRIVABLE_HIGHWAYS", "RoadEdge", "RoadNetwork", "is_drivable", "oneway_direction", "drive_network"]

DRIVABLE_HIGHWAYS = frozenset({
    "motorway", "trunk", "primary", "secondary", "tertiary", "unclassified", "residential", "living_street",
    "motorway_link", "trunk_link", "primary_link", "secondary_link", "tertiary_link",
})
"""``highway`` values a car drives (module docstring)."""
ACCESS_KEYS = ("motorcar", "motor_vehicle", "vehicle", "access")
"""Access tags, most specific first: the first one present decides."""
CLOSED = frozenset({"no", "private"})
WGS84_A = 6_378_137.0
WGS84_E2 = 6.694379990141317e-3
"""WGS84 semi-major axis (m) and first eccentricity squared, for the lengths."""


def is_drivable(tags: Mapping[str, str]) -> bool:
    """Whether a car may drive a way with these tags (module docstring)."""
    if tags.get("highway") not in DRIVABLE_HIGHWAYS or tags.get("area") == "yes":
        return False
    for key in ACCESS_KEYS:
        if key in tags:
            return tags[key] not in CLOSED
    return True


def oneway_direction(tags: Mapping[str, str]) -> int:
    """1: one-way in drawing order; -1: one-way against it; 0: two-way (module docstring)."""
    value = tags.get("oneway")
    if value in ("yes", "true", "1"):
        return 1
    if value in ("-1", "reverse"):
        return -1
    if value is None and (tags.get("junction") in ("roundabout", "circular") or tags.get("highway") == "motorway"):
        return 1
    return 0


@dataclass(frozen=True)
class RoadEdge:
    """A road from junction to junction: ``points`` ``(lon, lat)`` in driving order (either way if two-way)."""

    points: tuple[tuple[float, float], ...]
    oneway: bool
    highway: str
    name: str
    way_ids: tuple[int, ...]
    length_m: float


@dataclass(frozen=True)
class RoadNetwork:
    """The kept edges, and how much of the drivable network was left out as not strongly connected."""

    edges: tuple[RoadEdge, ...]
    drivable_ways: int
    junctions: int
    junctions_dropped: int

    @property
    def length_m(self) -> float:
        return sum(edge.length_m for edge in self.edges)


@dataclass(frozen=True)
class _Segment:
    tail: int
    head: int
    oneway: bool
    way: Way


def drive_network(ways: Iterable[Way], box: Box) -> RoadNetwork:
    """The drivable network of ``ways`` inside ``box`` (module docstring)."""
    segments, where, drivable = _segments(ways, box)
    ends: dict[int, list[int]] = {}  # node -> the segments that touch it
    for index, segment in enumerate(segments):
        ends.setdefault(segment.tail, []).append(index)
        ends.setdefault(segment.head, []).append(index)
    junctions = {node for node, touching in ends.items() if _is_junction(node, touching, segments)}
    chains = _chains(segments, ends, junctions)
    kept, total, dropped = _strongly_connected(chains, segments)
    edges = sorted((_edge(chain, segments, where) for chain in kept),
                   key=lambda edge: (edge.points[0], edge.points[-1], edge.points))
    return RoadNetwork(tuple(edges), drivable, total, dropped)


def _segments(ways: Iterable[Way], box: Box) -> tuple[list[_Segment], dict[int, tuple[float, float]], int]:
    """Every drivable segment inside the box (one-way ones in driving order), the points' coordinates, and the
    number of drivable ways."""
    new_key = itertools.count(-1, -1)
    segments: list[_Segment] = []
    where: dict[int, tuple[float, float]] = {}
    drivable = 0
    for way in sorted(ways, key=lambda w: w.osm_id):
        if not is_drivable(way.tags):
            continue
        drivable += 1
        direction = oneway_direction(way.tags)
        nodes = way.nodes[::-1] if direction < 0 else way.nodes
        for present, group in itertools.groupby(nodes, key=lambda node: node is not None):
            if not present:
                continue
            points: list[Point] = [node for node in group if node is not None]
            for run in clipped_runs(box, points, new_key):
                for a, b in zip(run, run[1:]):
                    where[a[0]], where[b[0]] = a[1:], b[1:]
                    if a[0] != b[0]:
                        segments.append(_Segment(a[0], b[0], direction != 0, way))
    return segments, where, drivable


def _is_junction(node: int, touching: list[int], segments: list[_Segment]) -> bool:
    if len(touching) != 2:
        return True
    first, second = segments[touching[0]], segments[touching[1]]
    if first.oneway != second.oneway:
        return True
    # Two one-way roads continue each other only when one arrives where the other leaves.
    return first.oneway and (first.head == node) == (second.head == node)


def _chains(segments: list[_Segment], ends: dict[int, list[int]], junctions: set[int]) -> list[list[tuple[int, bool]]]:
    """Segments merged from junction to junction: each chain a list of ``(segment, walked_forward)``."""
    used = [False] * len(segments)
    chains = []
    starts = sorted(junctions)
    while True:
        for node in starts:
            for first in ends[node]:
                if not used[first]:
                    chains.append(_walk(node, first, segments, ends, junctions, used))
        left = [i for i, done in enumerate(used) if not done]
        if not left:
            return chains
        cut = min(min(segments[i].tail, segments[i].head) for i in left)  # a loop without junctions
        junctions.add(cut)
        starts = [cut]


def _walk(node: int, first: int, segments: list[_Segment], ends: dict[int, list[int]], junctions: set[int],
          used: list[bool]) -> list[tuple[int, bool]]:
    chain, index = [], first
    while True:
        used[index] = True
        segment = segments[index]
        forward = segment.tail == node
        chain.append((index, forward))
        node = segment.head if forward else segment.tail
        if node in junctions:
            return chain
        index = next(i for i in ends[node] if i != index)


def _chain_ends(chain: list[tuple[int, bool]], segments: list[_Segment]) -> tuple[int, int]:
    first, forward = chain[0]
    last, last_forward = chain[-1]
    start = segments[first].tail if forward else segments[first].head
    end = segments[last].head if last_forward else segments[last].tail
    return start, end


def _strongly_connected(chains: list[list[tuple[int, bool]]], segments: list[_Segment]
                        ) -> tuple[list[list[tuple[int, bool]]], int, int]:
    """The chains inside the largest strongly connected set of junctions, the number of junctions, and how many
    of them were left out."""
    if not chains:
        return [], 0, 0
    pairs = [_chain_ends(chain, segments) for chain in chains]
    nodes = sorted({node for pair in pairs for node in pair})
    number = {node: i for i, node in enumerate(nodes)}
    tails: list[int] = []
    heads: list[int] = []
    for chain, (a, b) in zip(chains, pairs):
        oneway, forward = segments[chain[0][0]].oneway, chain[0][1]
        if not oneway or forward:
            tails.append(number[a])
            heads.append(number[b])
        if not oneway or not forward:
            tails.append(number[b])
            heads.append(number[a])
    arcs = coo_matrix((np.ones(len(tails)), (np.array(tails, dtype=np.intp), np.array(heads, dtype=np.intp))),
                      shape=(len(nodes), len(nodes)))
    _, labels = connected_components(arcs, directed=True, connection="strong")
    largest = np.bincount(labels).argmax()
    keep = [chain for chain, (a, b) in zip(chains, pairs) if labels[number[a]] == largest == labels[number[b]]]
    return keep, len(nodes), int(np.sum(labels != largest))


def _edge(chain: list[tuple[int, bool]], segments: list[_Segment], where: dict[int, tuple[float, float]]) -> RoadEdge:
    oneway = segments[chain[0][0]].oneway
    if oneway and not chain[0][1]:  # walked against the driving direction: turn it round
        chain = [(index, not forward) for index, forward in reversed(chain)]
    keys = [_chain_ends(chain[:1], segments)[0]]
    for index, forward in chain:
        keys.append(segments[index].head if forward else segments[index].tail)
    points = tuple(where[key] for key in keys)
    ways = [segments[index].way for index, _ in chain]
    name = next((way.tags["name"] for way in ways if way.tags.get("name")), "")
    length = sum(_distance_m(a, b) for a, b in zip(points, points[1:]))
    return RoadEdge(points, oneway, ways[0].tags["highway"], name, tuple(sorted({w.osm_id for w in ways})), length)


def _distance_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Length of a short segment between ``(lon, lat)`` points on the WGS84 ellipsoid, metres: at the mean latitude
    ``phi`` the radii of curvature of the meridian ``M = a (1 - e^2) / W^3`` and of the prime vertical ``N = a / W``,
    ``W = sqrt(1 - e^2 sin^2 phi)``, give ``dx = N cos(phi) d_lambda`` and ``dy = M d_phi``."""
    phi = math.radians(0.5 * (a[1] + b[1]))
    w = math.sqrt(1.0 - WGS84_E2 * math.sin(phi) ** 2)
    dx = WGS84_A / w * math.cos(phi) * math.radians(b[0] - a[0])
    dy = WGS84_A * (1.0 - WGS84_E2) / w**3 * math.radians(b[1] - a[1])
    return math.hypot(dx, dy)
