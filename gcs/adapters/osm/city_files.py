"""The buildings and roads of an OSM city as GeoJSON, in the formats the world loader reads.

Both files are RFC 7946 FeatureCollections in WGS84 ``[lon, lat]`` degrees (the
loader's default frame, :mod:`gcs.config.world`), rounded to 7 decimals (OSM
stores 1e-7 degrees, about a centimetre). Each carries the data's notice as
foreign members, ``"attribution"``, ``"license"`` and ``"source"``: the files are
derived from OpenStreetMap and stay under the Open Database License.

* **Buildings** (``[city] geojson``): one feature per building, a ``Polygon`` (or a
  ``MultiPolygon`` for a relation of several outer rings, one building per ring
  to the loader), outer rings only; properties ``height`` (metres, the
  ``[city] height_property``), ``height_source`` (``height``, ``building:levels``
  or ``default``: :mod:`.heights`) and ``osm_id`` (``w123`` a way, ``r45`` a relation).
* **Roads** (``[city] roads_geojson``): one ``LineString`` per edge of the road
  network (:mod:`.road_network`), junction to junction, drawn in its driving
  direction; properties ``oneway`` (``"yes"`` or ``"no"``, the
  ``[city] roads_oneway_property``), ``highway``, ``name``, ``osm_ways`` and
  ``length_m``.

A building is kept whole when the centroid of its largest outer ring lies in the
box (:func:`select_buildings`), and left out otherwise: a footprint is never cut,
since a cut one would make a wall that is not there.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from gcs.adapters.osm.clipping import Box, inside
from gcs.adapters.osm.heights import building_height
from gcs.adapters.osm.reading import Building
from gcs.adapters.osm.road_network import RoadEdge

__all__ = ["ATTRIBUTION", "LICENCE", "LICENCE_URL", "PlacedBuilding", "select_buildings", "ring_centroid",
           "buildings_document", "roads_document"]

ATTRIBUTION = "© OpenStreetMap contributors"
LICENCE = "ODbL-1.0"
LICENCE_URL = "https://opendatacommons.org/licenses/odbl/1-0/"
DIGITS = 7
"""Decimals of a degree kept (OSM's own precision)."""


@dataclass(frozen=True)
class PlacedBuilding:
    """A building kept in the box: its OSM id, outer rings ``(lon, lat)``, roof height and where it came from."""

    osm_id: str
    rings: tuple[tuple[tuple[float, float], ...], ...]
    height_m: float
    height_source: str


def ring_centroid(ring: Sequence[tuple[float, float]]) -> tuple[float, float] | None:
    """Area centroid of a closed ring ``(lon, lat)`` (shoelace: ``c = sum (p_i + p_i+1)(p_i x p_i+1) / (6 A)``), or
    None for a ring of no area. Coordinates are taken relative to the first vertex, so that degrees lose no
    digits."""
    x0, y0 = ring[0]
    area = cx = cy = 0.0
    for (xa, ya), (xb, yb) in zip(ring, list(ring[1:]) + [ring[0]]):
        xa, ya, xb, yb = xa - x0, ya - y0, xb - x0, yb - y0
        cross = xa * yb - xb * ya
        area += cross
        cx += (xa + xb) * cross
        cy += (ya + yb) * cross
    if area == 0.0:
        return None
    return x0 + cx / (3.0 * area), y0 + cy / (3.0 * area)


def select_buildings(buildings: Iterable[Building], box: Box, default_height_m: float) -> list[PlacedBuilding]:
    """The buildings whose largest outer ring's centroid lies in ``box``, with their heights, by OSM id."""
    kept = []
    for building in buildings:
        rings = tuple(ring for ring in building.rings if len(set(ring)) >= 3 and ring_centroid(ring) is not None)
        if not rings:
            continue
        largest = max(rings, key=lambda ring: abs(_twice_area(ring)))
        centroid = ring_centroid(largest)
        if centroid is None or not inside(box, *centroid):
            continue
        height, source = building_height(building.tags, default_height_m)
        kept.append(PlacedBuilding(building.osm_id, rings, height, source))
    return sorted(kept, key=lambda b: (b.osm_id[0], int(b.osm_id[1:])))


def _twice_area(ring: Sequence[tuple[float, float]]) -> float:
    x0, y0 = ring[0]
    return sum((xa - x0) * (yb - y0) - (xb - x0) * (ya - y0)
               for (xa, ya), (xb, yb) in zip(ring, list(ring[1:]) + [ring[0]]))


def _notice(source: str) -> dict:
    return {"attribution": ATTRIBUTION, "license": LICENCE, "source": source}


def _point(p: tuple[float, float]) -> list[float]:
    return [round(p[0], DIGITS), round(p[1], DIGITS)]


def _closed(ring: Sequence[tuple[float, float]]) -> list[list[float]]:
    points = [_point(p) for p in ring]
    return points if points[0] == points[-1] else points + points[:1]


def buildings_document(buildings: Sequence[PlacedBuilding], source: str) -> dict:
    """The buildings' FeatureCollection (module docstring); ``source`` names the extract."""
    features = []
    for building in buildings:
        polygons = [[_closed(ring)] for ring in building.rings]
        geometry = ({"type": "Polygon", "coordinates": polygons[0]} if len(polygons) == 1
                    else {"type": "MultiPolygon", "coordinates": polygons})
        features.append({"type": "Feature", "id": building.osm_id, "geometry": geometry,
                         "properties": {"height": round(building.height_m, 2), "height_source": building.height_source,
                                        "osm_id": building.osm_id}})
    return {"type": "FeatureCollection", **_notice(source), "features": features}


def roads_document(edges: Sequence[RoadEdge], source: str) -> dict:
    """The roads' FeatureCollection (module docstring); ``source`` names the extract."""
    features = [{"type": "Feature",
                 "geometry": {"type": "LineString", "coordinates": [_point(p) for p in edge.points]},
                 "properties": {"oneway": "yes" if edge.oneway else "no", "highway": edge.highway, "name": edge.name,
                                "osm_ways": list(edge.way_ids), "length_m": round(edge.length_m, 1)}}
                for edge in edges]
    return {"type": "FeatureCollection", **_notice(source), "features": features}
