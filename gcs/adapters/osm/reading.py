"""Reading an OpenStreetMap extract (``.osm.pbf`` or ``.osm`` XML) with pyosmium, in one pass.

What the scenario builder needs from the file:

* the **buildings**: every area (closed way or multipolygon relation) tagged
  ``building`` (not ``building=no``), as its outer rings in ``(lon, lat)`` degrees
  with its height tags; libosmium's area assembler leaves out a building whose
  ring is not complete in the extract (a way cut at the extract's edge);
* the **highway ways**: every way tagged ``highway``, with its tags and its nodes
  ``(id, lon, lat)``, a node missing from the extract given as None;
* the **extent of the data**: the file header's box when it has one, else the
  bounding box of the nodes' locations;
* the **date of the data**: the header's ``osmosis_replication_timestamp`` when
  set, else the newest element's timestamp (None if no element carries one).

pyosmium (the ``osmium`` package, the optional extra ``osm``) is imported when a
file is read, so that ``gcs --help`` and the rest of ``gcs`` never load it;
without it, :class:`OsmUnavailable` says how to install it.
"""

from __future__ import annotations

import datetime
import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["OsmUnavailable", "OsmReadError", "Building", "Way", "Extract", "INSTALL_HINT", "read_extract"]

INSTALL_HINT = "pip install 'uav-tracking-gcs[osm]'"
"""How to get pyosmium, the library that reads OSM files."""
WAY_TAGS = ("highway", "oneway", "junction", "area", "access", "vehicle", "motor_vehicle", "motorcar", "name")
"""The tags of a highway way that the road network reads."""
BUILDING_TAGS = ("building", "height", "building:levels")

LonLat = tuple[float, float]


class OsmUnavailable(RuntimeError):
    """pyosmium is not installed."""


class OsmReadError(ValueError):
    """The file is not an OSM extract that libosmium can read."""


@dataclass(frozen=True)
class Building:
    """One building: ``osm_id`` ("w123" for a way, "r45" for a relation), outer rings, its height tags."""

    osm_id: str
    rings: tuple[tuple[LonLat, ...], ...]
    tags: dict[str, str]


@dataclass(frozen=True)
class Way:
    """One ``highway`` way: id, tags (:data:`WAY_TAGS`) and nodes ``(id, lon, lat)`` (None where missing)."""

    osm_id: int
    tags: dict[str, str]
    nodes: tuple[tuple[int, float, float] | None, ...]


@dataclass
class Extract:
    """What :func:`read_extract` found (module docstring)."""

    buildings: list[Building] = field(default_factory=list)
    ways: list[Way] = field(default_factory=list)
    data_box: tuple[float, float, float, float] | None = None
    """``west, south, east, north`` degrees."""
    data_box_source: str = "none"
    """"header" (the file says) or "nodes" (their locations)."""
    data_date: datetime.datetime | None = None
    data_date_source: str = "none"
    """"header" (replication timestamp) or "newest element"."""


def _osmium() -> Any:
    try:
        return importlib.import_module("osmium")
    except ImportError:
        raise OsmUnavailable(f"reading OpenStreetMap files needs pyosmium: {INSTALL_HINT}") from None


def read_extract(path: Path) -> Extract:
    """Everything the scenario builder needs from ``path``, in one pass (module docstring).

    Raises
    ------
    OsmUnavailable
        pyosmium is not installed.
    OsmReadError
        libosmium cannot read the file (its format follows the name: ``.osm.pbf``, ``.osm``, ``.osm.gz``, ...).
    """
    osmium = _osmium()
    found = Extract()
    try:
        _read_header(osmium, path, found)
        _read_objects(osmium, path, found)
    except RuntimeError as exc:  # libosmium's io errors (bad format, unknown suffix, truncated file)
        raise OsmReadError(f"{path}: not a readable OSM file (.osm.pbf or .osm XML): {exc}") from None
    return found


def _read_header(osmium: Any, path: Path, found: Extract) -> None:
    reader = osmium.io.Reader(str(path), osmium.osm.osm_entity_bits.NOTHING)
    try:
        header = reader.header()
        box = header.box()
        if box.valid():
            found.data_box = (box.bottom_left.lon, box.bottom_left.lat, box.top_right.lon, box.top_right.lat)
            found.data_box_source = "header"
        stamp = header.get("osmosis_replication_timestamp", "")
        if stamp:
            found.data_date = datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00"))
            found.data_date_source = "header"
    finally:
        reader.close()


def _read_objects(osmium: Any, path: Path, found: Extract) -> None:
    newest = None
    west = south = float("inf")
    east = north = float("-inf")
    processor = osmium.FileProcessor(str(path)).with_locations().with_areas(osmium.filter.KeyFilter("building"))
    for item in processor:
        if item.is_area():
            if item.tags.get("building", "no") != "no":
                found.buildings.append(_building(item))
            continue
        stamp = item.timestamp
        if stamp is not None and stamp.timestamp() > 0 and (newest is None or stamp > newest):
            newest = stamp
        if item.is_node():
            if item.location.valid():
                lon, lat = item.location.lon, item.location.lat
                west, east, south, north = min(west, lon), max(east, lon), min(south, lat), max(north, lat)
        elif item.is_way() and "highway" in item.tags:
            found.ways.append(_way(item))
    if found.data_box is None and west <= east:
        found.data_box, found.data_box_source = (west, south, east, north), "nodes"
    if found.data_date is None and newest is not None:
        found.data_date, found.data_date_source = newest, "newest element"


def _building(area: Any) -> Building:
    kind = "w" if area.from_way() else "r"
    rings = tuple(tuple((node.lon, node.lat) for node in ring) for ring in area.outer_rings())
    tags = {key: area.tags[key] for key in BUILDING_TAGS if key in area.tags}
    return Building(f"{kind}{area.orig_id()}", rings, tags)


def _way(way: Any) -> Way:
    nodes = tuple((node.ref, node.lon, node.lat) if node.location.valid() else None for node in way.nodes)
    tags = {key: way.tags[key] for key in WAY_TAGS if key in way.tags}
    return Way(int(way.id), tags, nodes)
