"""A small OpenStreetMap extract that the tests write themselves: plain .osm XML, or .osm.pbf through pyosmium.

The town lies about ``ORIGIN`` (Helsinki), drawn in ENU metres and converted with
:class:`gcs.core.geometry.LocalFrame`. Streets (100 m blocks)::

    G(0,200) --- H(100,200) --- I(200,200) ==> K(400,200)   one-way, leaves the box
      |             ^             |
    D(0,100) --- E(100,100) --- F(200,100) --- (400,100)   two-way, crosses the box's edge
      |             ^  footway    |  (tertiary)
    A(0,0) ----- B(100,0) ----- C(200,0)
                 one-way B -> E -> H

plus a footway A -> (50, 50) -> E, a private residential stub and a service road,
which a car may not drive. The box is ``[-50, 250] x [-50, 250]`` m: the east stub
is cut at x = 250, and the one-way I -> K leaves it. The data's own bounds (the
XML's ``<bounds>``) reach 600 m to the east, so there is an empty box in the file.

Buildings (closed ways unless said): height "12 m"; height "40 ft"; levels 4; no
height at all; one whose centroid is in the box though it crosses the edge; one
whose centroid is beyond the edge; ``building=no``; a ``building:part`` with a
height; and a multipolygon relation with a courtyard, levels 2.5.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from pathlib import Path

from gcs.core.geometry import LocalFrame

__all__ = ["ORIGIN", "BOX_M", "DATA_M", "NEWEST", "EXPECTED", "box_degrees", "write_xml", "write_pbf", "ROADS"]

ORIGIN = (60.17, 24.94)
FRAME = LocalFrame(*ORIGIN, 0.0)
BOX_M = (-50.0, -50.0, 250.0, 250.0)
DATA_M = (-100.0, -100.0, 600.0, 300.0)
NEWEST = "2024-05-06T07:08:09Z"
OLDER = "2023-01-02T03:04:05Z"

POINTS = {
    1: (0, 0), 2: (100, 0), 3: (200, 0), 4: (0, 100), 5: (100, 100), 6: (200, 100), 7: (0, 200), 8: (100, 200),
    9: (200, 200), 10: (400, 100), 11: (400, 200), 12: (50, 50), 13: (200, 240), 14: (150, 20), 15: (150, 80),
}


def _square(first_id: int, x0: float, y0: float, x1: float, y1: float) -> dict[int, tuple[float, float]]:
    return {first_id: (x0, y0), first_id + 1: (x1, y0), first_id + 2: (x1, y1), first_id + 3: (x0, y1)}


BUILDING_CORNERS = {
    201: _square(1000, 10, 10, 45, 90),  # height "12 m"
    202: _square(1010, 55, 10, 90, 90),  # height "40 ft"
    203: _square(1020, 110, 10, 190, 45),  # building:levels 4
    204: _square(1030, 110, 55, 190, 90),  # no height tag
    205: _square(1040, 215, 110, 275, 190),  # crosses x = 250, centroid at x = 245: kept whole
    206: _square(1050, 235, 10, 305, 90),  # crosses x = 250, centroid at x = 270: left out
    207: _square(1060, 110, 110, 190, 190),  # building=no
    208: _square(1070, 120, 120, 150, 150),  # building:part with height 99
    311: _square(1080, 10, 110, 90, 190),  # outer ring of relation 301
    312: _square(1090, 30, 130, 70, 170),  # courtyard (inner) of relation 301
}
BUILDING_TAGS = {
    201: {"building": "yes", "height": "12 m"},
    202: {"building": "yes", "height": "40 ft"},
    203: {"building": "apartments", "building:levels": "4"},
    204: {"building": "yes"},
    205: {"building": "yes", "height": "30"},
    206: {"building": "yes", "height": "30"},
    207: {"building": "no"},
    208: {"building:part": "yes", "height": "99"},
    311: {},
    312: {},
}

ROADS = {  # way id: (nodes, tags)
    101: ([1, 2, 3], {"highway": "residential", "name": "South Street"}),
    102: ([4, 5, 6], {"highway": "residential"}),
    103: ([7, 8, 9], {"highway": "residential"}),
    104: ([1, 4, 7], {"highway": "residential"}),
    105: ([3, 6, 9], {"highway": "tertiary"}),
    106: ([2, 5, 8], {"highway": "residential", "oneway": "yes"}),
    107: ([6, 10], {"highway": "residential"}),
    108: ([9, 11], {"highway": "unclassified", "oneway": "yes"}),
    109: ([1, 12, 5], {"highway": "footway"}),
    110: ([9, 13], {"highway": "residential", "access": "private"}),
    111: ([14, 15], {"highway": "service", "service": "driveway"}),
}


@dataclass(frozen=True)
class Expected:
    """What the importer must find, worked out by hand from the drawing above."""

    heights: dict[str, tuple[float, str]]
    road_lengths_m: tuple[float, ...]
    oneway_edges: int
    excluded_ways: tuple[int, ...]


EXPECTED = Expected(
    heights={"w201": (12.0, "height"), "w202": (12.192, "height"), "w203": (12.0, "building:levels"),
             "w204": (15.0, "default"), "w205": (30.0, "height"), "r301": (7.5, "building:levels")},
    # B-A-D, B-C-F and D-G-H (bends), D-E, E-F, H-I, F-I, B->E, E->H, and F-J cut at x = 250
    road_lengths_m=(200.0, 200.0, 200.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 50.0),
    oneway_edges=2,
    excluded_ways=(108, 109, 110, 111),
)


def lon_lat(x: float, y: float) -> tuple[float, float]:
    lat, lon, _ = FRAME.to_geodetic([x, y, 0.0])
    return round(float(lon), 7), round(float(lat), 7)


def box_degrees(box_m: tuple[float, float, float, float] = BOX_M) -> tuple[float, float, float, float]:
    """``W,S,E,N`` of an ENU box (its corners' longitudes and latitudes)."""
    west, south = lon_lat(box_m[0], box_m[1])
    east, north = lon_lat(box_m[2], box_m[3])
    return west, south, east, north


def _nodes() -> dict[int, tuple[float, float]]:
    nodes = {node: lon_lat(*xy) for node, xy in POINTS.items()}
    for corners in BUILDING_CORNERS.values():
        nodes.update({node: lon_lat(*xy) for node, xy in corners.items()})
    return nodes


def _ways() -> dict[int, tuple[list[int], dict[str, str]]]:
    ways = dict(ROADS)
    for way, corners in BUILDING_CORNERS.items():
        ids = list(corners)
        ways[way] = (ids + ids[:1], BUILDING_TAGS[way])
    return dict(sorted(ways.items()))


RELATION = (301, [("w", 311, "outer"), ("w", 312, "inner")], {"type": "multipolygon", "building": "yes",
                                                                 "building:levels": "2.5"})


def _tags_xml(tags: dict[str, str]) -> str:
    return "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())


def write_xml(path: Path) -> Path:
    """The extract as OSM XML 0.6 with a ``<bounds>`` element (:data:`DATA_M`); the newest element is way 101."""
    west, south, east, north = box_degrees(DATA_M)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="tests">',
             f'<bounds minlat="{south}" minlon="{west}" maxlat="{north}" maxlon="{east}"/>']
    for node, (lon, lat) in sorted(_nodes().items()):
        lines.append(f'<node id="{node}" version="1" timestamp="{OLDER}" lat="{lat}" lon="{lon}"/>')
    for way, (nodes, tags) in _ways().items():
        stamp = NEWEST if way == 101 else OLDER
        refs = "".join(f'<nd ref="{n}"/>' for n in nodes)
        lines.append(f'<way id="{way}" version="1" timestamp="{stamp}">{refs}{_tags_xml(tags)}</way>')
    rel, members, tags = RELATION
    refs = "".join(f'<member type="way" ref="{ref}" role="{role}"/>' for _, ref, role in members)
    lines.append(f'<relation id="{rel}" version="1" timestamp="{OLDER}">{refs}{_tags_xml(tags)}</relation>')
    path.write_text("\n".join(lines + ["</osm>"]) + "\n", encoding="utf-8")
    return path


def write_pbf(path: Path, bounds: bool = True) -> Path:
    """The same extract as .osm.pbf, written with pyosmium's SimpleWriter, with the header box :data:`DATA_M`
    (``bounds``) or none (then the data's extent is its nodes')."""
    import osmium
    from osmium.osm.mutable import Node, Relation, Way

    def stamp(text: str) -> datetime.datetime:
        return datetime.datetime.fromisoformat(text.replace("Z", "+00:00"))

    header = osmium.io.Header()
    if bounds:
        west, south, east, north = box_degrees(DATA_M)
        header.add_box(osmium.osm.Box(osmium.osm.Location(west, south), osmium.osm.Location(east, north)))
    with osmium.SimpleWriter(str(path), header=header, overwrite=True) as writer:
        for node, location in sorted(_nodes().items()):
            writer.add_node(Node(id=node, version=1, location=location, tags={}, timestamp=stamp(OLDER)))
        for way, (nodes, tags) in _ways().items():
            writer.add_way(Way(id=way, version=1, nodes=nodes, tags=tags, timestamp=stamp(NEWEST if way == 101 else OLDER)))
        rel, members, tags = RELATION
        writer.add_relation(Relation(id=rel, version=1, members=members, tags=tags, timestamp=stamp(OLDER)))
    return path
