"""Build the :class:`gcs.core.world.World` a scenario describes (reads files; not part of the core).

``[city]``
    ``kind = "generated"``: :func:`gcs.core.world.generate_city` with
    ``numpy.random.default_rng(city.seed)`` and the table's size, count, street
    width and height range. ``kind = "geojson"``: footprints from
    ``city.geojson`` (a path relative to ``base_dir``, normally the scenario
    file's folder), roof heights from the ``city.height_property`` property.
    ``kind = "empty"``: no buildings.

GeoJSON coordinates
    By default (RFC 7946) coordinates are WGS84 ``[lon_deg, lat_deg]`` and are
    converted to the scenario's local ENU frame
    (:class:`gcs.core.geometry.LocalFrame` at ``[origin]``). A FeatureCollection
    with the top-level member ``"gcs_frame": "enu"`` instead holds ENU metres
    ``[x_east, y_north]`` directly (``"gcs_frame": "wgs84"`` states the default).
    Only outer rings are used; holes are ignored (see
    :func:`gcs.core.world.buildings_from_geojson`).

``city.roads_geojson``
    The road network (:func:`gcs.core.roads.roads_from_geojson`): LineStrings in
    the same coordinate convention as the buildings' file (below), one-way roads
    marked by ``city.roads_oneway_property``. Without it a generated city's
    street grid is its road graph (:func:`gcs.core.roads.roads_from_street_grid`);
    other cities have none.

The world's extent
    A generated city (and an empty one without roads) is its ``city.size_m``
    rectangle from the ENU origin. A GeoJSON city, or an empty city with roads, is
    framed on its content: the bounding box of its footprints, its road nodes and
    the scenario's start points (vehicles and targets), with
    :data:`gcs.core.world.FRAME_MARGIN_M` around it (:mod:`gcs.core.world.extent`).

File names
    A relative path resolves against ``base_dir`` (the scenario file's folder).
    Without one it resolves against the current directory, and failing that
    against the shipped scenarios' folder (:mod:`gcs.scenarios`), where a
    shipped scenario's GeoJSON files sit beside it.

``[[restricted]]``
    Each zone becomes one polygon prism of :class:`gcs.core.world.RestrictedAirspace`.

Every problem raises :class:`gcs.config.ScenarioError` naming the file.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.config import CityConfig, Origin, RestrictedAirspace as AirspaceConfig, Scenario, ScenarioError
from gcs.core.geometry import LocalFrame
from gcs.core.roads import RoadGraph, roads_from_geojson, roads_from_street_grid
from gcs.core.world import Buildings, RestrictedAirspace, World, buildings_from_geojson, content_bounds, generate_city

__all__ = ["build_world", "load_city_geojson", "load_roads_geojson", "airspace_from_config", "resolve_path"]

ToEnu = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.float64]]]
"""``to_enu(lon_deg, lat_deg) -> (x_m, y_m)`` on arrays."""

GCS_FRAME_KEY = "gcs_frame"
"""Top-level FeatureCollection member naming the coordinate frame: "enu" or "wgs84"."""


def build_world(scenario: Scenario, base_dir: Path | None = None) -> World:
    """The buildings, streets, road graph and restricted airspace of a scenario.

    Parameters
    ----------
    scenario : gcs.config.Scenario
    base_dir : pathlib.Path, optional
        Folder that relative paths in the scenario (``city.geojson``) are
        resolved against; the current directory when omitted.

    Raises
    ------
    gcs.config.ScenarioError
        Unreadable or invalid GeoJSON, impossible city parameters or bad zones.
    """
    city = scenario.city
    streets = None
    if city.kind == "generated":
        try:
            buildings, streets = generate_city(
                np.random.default_rng(city.seed), size_m=city.size_m, buildings=city.buildings,
                street_width_m=city.street_width_m, min_height_m=city.min_height_m, max_height_m=city.max_height_m,
            )
        except ValueError as exc:
            raise ScenarioError(f"{scenario.name}: $.city: {exc}") from None
    elif city.kind == "geojson":
        buildings = load_city_geojson(city, scenario.origin, base_dir)
    else:
        buildings = Buildings.empty()
    airspace = airspace_from_config(scenario.restricted, source=scenario.name)
    roads: RoadGraph | None
    if city.roads_geojson:
        roads = load_roads_geojson(city, scenario.origin, base_dir)
    else:
        roads = roads_from_street_grid(streets) if streets is not None else None
    bounds = None
    if city.framed_on_content:
        starts = [v.start_enu_m for v in scenario.vehicles] + [t.start_enu_m for t in scenario.all_targets]
        bounds = content_bounds(buildings, roads, starts)
    return World(buildings, airspace, streets, (float(city.size_m[0]), float(city.size_m[1])), roads, bounds)


def load_city_geojson(city: CityConfig, origin: Origin, base_dir: Path | None = None) -> Buildings:
    """Read ``city.geojson`` (see the module docstring for the coordinate convention)."""
    if not city.geojson:
        raise ScenarioError("$.city.geojson: required when kind = 'geojson'")
    path, document = _read_geojson(city.geojson, base_dir, "GeoJSON city")
    try:
        to_enu = _converter(document, origin)
        return buildings_from_geojson(document, height_property=city.height_property, to_enu=to_enu)
    except ValueError as exc:
        raise ScenarioError(f"{path}: {exc}") from None


def load_roads_geojson(city: CityConfig, origin: Origin, base_dir: Path | None = None) -> RoadGraph:
    """Read ``city.roads_geojson``: the road graph of its LineStrings (same coordinate convention)."""
    if not city.roads_geojson:
        raise ScenarioError("$.city.roads_geojson: no roads file to read")
    path, document = _read_geojson(city.roads_geojson, base_dir, "GeoJSON roads")
    try:
        return roads_from_geojson(document, to_enu=_converter(document, origin),
                                  oneway_property=city.roads_oneway_property)
    except ValueError as exc:
        raise ScenarioError(f"{path}: $.city.roads_geojson: {exc}") from None


def _read_geojson(name: str, base_dir: Path | None, what: str) -> tuple[Path, Any]:
    """The path (relative to ``base_dir``) and parsed contents of a GeoJSON file; ScenarioError naming it."""
    path = resolve_path(name, base_dir)
    try:
        with path.open("rb") as handle:
            return path, json.load(handle)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: not valid JSON: {exc}") from None


def resolve_path(name: str, base_dir: Path | None) -> Path:
    """Where a file a scenario names is: absolute as given; else under ``base_dir``; without one, under the
    current directory, or failing that under the shipped scenarios' folder (module docstring)."""
    path = Path(name)
    if path.is_absolute():
        return path
    if base_dir is not None:
        return base_dir / path
    here = Path.cwd() / path
    if here.exists():
        return here
    shipped = Path(str(resources.files("gcs.scenarios"))) / path
    return shipped if shipped.exists() else here


def _converter(document: Any, origin: Origin) -> ToEnu | None:
    """None for ENU files, else a lon/lat -> ENU function about the scenario origin."""
    frame = document.get(GCS_FRAME_KEY, "wgs84") if isinstance(document, dict) else "wgs84"
    if frame == "enu":
        return None
    if frame != "wgs84":
        raise ValueError(f"{GCS_FRAME_KEY!r} must be \"enu\" or \"wgs84\", got {frame!r}")
    local = LocalFrame(origin.lat_deg, origin.lon_deg, origin.height_m)

    def to_enu(lon_deg: NDArray[np.float64], lat_deg: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if np.any(np.abs(lat_deg) > 90.0) or np.any(np.abs(lon_deg) > 180.0):
            raise ValueError(f"coordinates are not [lon, lat] degrees (set \"{GCS_FRAME_KEY}\": \"enu\" for metres)")
        enu = local.to_enu(lat_deg, lon_deg, origin.height_m)
        return enu[..., 0], enu[..., 1]

    return to_enu


def airspace_from_config(zones: Sequence[AirspaceConfig], source: str = "scenario") -> RestrictedAirspace:
    """Core airspace arrays from the scenario's ``[[restricted]]`` tables."""
    try:
        return RestrictedAirspace.from_zones(
            [(zone.polygon_enu_m, zone.floor_m, zone.ceiling_m) for zone in zones],
            names=[zone.name for zone in zones],
        )
    except ValueError as exc:
        raise ScenarioError(f"{source}: $.restricted: {exc}") from None
