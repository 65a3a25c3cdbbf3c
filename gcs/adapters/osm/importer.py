"""``gcs scenario from-osm``'s work: an OSM extract and a box in, a scenario and its two GeoJSON files out.

:func:`build_osm_scenario` reads the extract (:mod:`.reading`), checks that the
box lies inside the file's data and holds something, keeps the buildings
(:func:`.city_files.select_buildings`, heights by :mod:`.heights`) and the
drivable road network (:mod:`.road_network`) of the box, and writes
``NAME_buildings.geojson`` and ``NAME_roads.geojson`` (:mod:`.city_files`) and
``NAME.toml`` (:mod:`.scenario_text`). The scenario it wrote is then loaded and
its world built (:func:`gcs.config.world.build_world`), so that a file that
would not load is never left as a success.
"""

from __future__ import annotations

import hashlib
import json
import statistics
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gcs.adapters.osm.city_files import (ATTRIBUTION, LICENCE, LICENCE_URL, PlacedBuilding, buildings_document,
                                         roads_document, select_buildings)
from gcs.adapters.osm.clipping import Box, box_text
from gcs.adapters.osm.reading import Extract, read_extract
from gcs.adapters.osm.road_network import RoadNetwork, drive_network
from gcs.adapters.osm.scenario_text import STREET_SPEED_MPS, CityLayout, scenario_text
from gcs.config import SourceConfig
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, parse_scenario

__all__ = ["OsmRequest", "OsmCity", "OsmBoxError", "build_osm_scenario"]


class OsmBoxError(ValueError):
    """The box reaches beyond the file's data, or holds neither buildings nor drivable roads."""


@dataclass(frozen=True)
class OsmRequest:
    """What to build: the extract, the box, the scenario file to write and the choices that shape it."""

    source: Path
    box: Box
    out: Path
    origin: tuple[float, float] | None
    """``(lat, lon)`` of the ENU origin; None: the box's centre."""
    default_height_m: float
    description: str | None
    command: str
    """The command line, as recorded in ``[source] command``."""


@dataclass(frozen=True)
class OsmCity:
    """What was written, and the figures the command prints."""

    scenario: Path
    buildings_file: Path
    roads_file: Path | None
    buildings: tuple[PlacedBuilding, ...]
    roads: RoadNetwork
    data_date: str

    def count(self, source: str) -> int:
        """Buildings whose height came from ``source`` (:data:`gcs.adapters.osm.heights.HEIGHT_SOURCES`)."""
        return sum(1 for building in self.buildings if building.height_source == source)

    @property
    def tagged_median_m(self) -> float | None:
        """Median roof height of the buildings whose height was tagged (not the default), metres."""
        tagged = [b.height_m for b in self.buildings if b.height_source != "default"]
        return statistics.median(tagged) if tagged else None


def build_osm_scenario(request: OsmRequest) -> OsmCity:
    """Read, select, write and check (module docstring).

    Raises
    ------
    gcs.adapters.osm.reading.OsmUnavailable, gcs.adapters.osm.reading.OsmReadError
        From reading the extract.
    OsmBoxError
        The box reaches beyond the file's data or is empty.
    """
    extract = read_extract(request.source)
    _check_box(request, extract)
    buildings = tuple(select_buildings(extract.buildings, request.box, request.default_height_m))
    roads = drive_network(extract.ways, request.box)
    if not buildings and not roads.edges:
        raise OsmBoxError(f"--bbox {box_text(request.box)}: no buildings and no drivable roads in this box of "
                          f"{request.source.name}; give a box over a built-up area")
    west, south, east, north = request.box
    origin = request.origin or (round(0.5 * (south + north), 7), round(0.5 * (west + east), 7))
    frame = LocalFrame(origin[0], origin[1], 0.0)
    centre = frame.to_enu(0.5 * (south + north), 0.5 * (west + east), 0.0)[:2]
    layout = CityLayout((round(float(centre[0]), 1), round(float(centre[1]), 1)), _nearest_road_point(roads, frame, centre),
                        max((b.height_m for b in buildings), default=0.0))
    data_date = "" if extract.data_date is None else \
        f"{extract.data_date:%Y-%m-%dT%H:%M:%SZ} ({extract.data_date_source})"
    source = SourceConfig(attribution=ATTRIBUTION, licence=LICENCE, licence_url=LICENCE_URL,
                          file=request.source.name, sha256=_sha256(request.source), data_date=data_date,
                          command=request.command)
    name = request.out.stem
    buildings_file = request.out.with_name(f"{name}_buildings.geojson")
    roads_file = request.out.with_name(f"{name}_roads.geojson") if roads.edges else None
    notice = f"{ATTRIBUTION}, {LICENCE}: {request.source.name}" + (f", data of {data_date}" if data_date else "")
    _write_geojson(buildings_file, buildings_document(buildings, notice))
    if roads_file is not None:
        _write_geojson(roads_file, roads_document(roads.edges, notice))
    description = request.description or (
        f"{len(buildings)} buildings and {roads.length_m / 1000.0:.1f} km of roads from OpenStreetMap "
        f"({request.source.name})" + (f"; a car driving its streets at {STREET_SPEED_MPS:g} m/s" if roads.edges else ""))
    text = scenario_text(name, description, source, origin,
                         (buildings_file.name, roads_file.name if roads_file else None), layout,
                         load_scenario(DEFAULT_SCENARIO))
    build_world(parse_scenario(text, source=str(request.out)), request.out.parent)
    request.out.write_text(text, encoding="utf-8")
    return OsmCity(request.out, buildings_file, roads_file, buildings, roads, data_date)


def _check_box(request: OsmRequest, extract: Extract) -> None:
    if extract.data_box is None:
        raise OsmBoxError(f"{request.source}: holds no located nodes (not an extract of map data)")
    west, south, east, north = request.box
    d_west, d_south, d_east, d_north = extract.data_box
    if west < d_west or south < d_south or east > d_east or north > d_north:
        raise OsmBoxError(f"--bbox {box_text(request.box)}: reaches beyond the data of {request.source.name} "
                          f"({box_text(extract.data_box)}, from its {extract.data_box_source}); give a box inside it")


def _nearest_road_point(roads: RoadNetwork, frame: LocalFrame, centre: np.ndarray) -> tuple[float, float] | None:
    if not roads.edges:
        return None
    points = np.array([p for edge in roads.edges for p in edge.points])
    enu = frame.to_enu(points[:, 1], points[:, 0], np.zeros(len(points)))[:, :2]
    nearest = enu[np.argmin(np.hypot(*(enu - centre).T))]
    return round(float(nearest[0]), 1), round(float(nearest[1]), 1)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _write_geojson(path: Path, document: dict) -> None:
    """One feature a line, so that a regenerated file's changes read well in a diff."""
    head = {key: value for key, value in document.items() if key != "features"}
    features = ",\n".join(json.dumps(feature, ensure_ascii=False) for feature in document["features"])
    text = json.dumps(head, ensure_ascii=False)[:-1] + ', "features": [\n' + features + "\n]}\n"
    path.write_text(text, encoding="utf-8")
