"""The scenario TOML of an OSM city: its source and notice, origin, city files, and the default scenario's rest.

What the file holds, table by table:

* ``name``, ``description``; ``[source]`` (:class:`gcs.config.SourceConfig`): the
  attribution, the licence, the extract's file name, SHA-256 and date, and the
  command line that built the scenario;
* ``[origin]``: the geodetic origin of the ENU frame, ``height_m = 0`` (OSM has no
  elevation: the ground is taken as the ellipsoid's surface);
* ``[city]``: ``kind = "geojson"`` with the two files beside the TOML;
* ``[time]``, ``[sensor]`` and ``[[vehicles]]``: the default scenario's
  (:data:`gcs.scenarios.DEFAULT_SCENARIO`), each vehicle placed at the same offset
  from the new city's centre as from the default city's, and all of them lifted
  together if needed so that the lowest flies :data:`CLEARANCE_M` above the
  tallest roof;
* ``[target]``: a car that drives the streets (``motion = "streets"``, at
  :data:`STREET_SPEED_MPS`) from the road point nearest the centre; a box without
  roads gets the default scenario's free-driving target at the centre instead;
* ``[estimator]``, ``[planner]``: left out, so the class defaults apply.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import msgspec

from gcs.config import Scenario, SourceConfig

__all__ = ["STREET_SPEED_MPS", "CLEARANCE_M", "CityLayout", "scenario_text", "toml_value"]

STREET_SPEED_MPS = 8.0
"""The car's cruising speed, m/s (29 km/h: city-centre traffic)."""
CLEARANCE_M = 50.0
"""Least height of the lowest UAV above the tallest roof, metres."""


@dataclass(frozen=True)
class CityLayout:
    """Where things are in the new city's ENU frame, metres: its centre, the car's start, the tallest roof."""

    centre: tuple[float, float]
    target_start: tuple[float, float] | None
    """The road point nearest the centre; None without roads."""
    tallest_roof_m: float


def toml_value(value: Any) -> str:
    """A TOML literal of a string, bool, number or list of them (strings as JSON-escaped basic strings)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"TOML has no literal for {value!r} here")
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    raise TypeError(f"no TOML literal for {type(value).__name__}")


def _table(header: str, values: Mapping[str, Any], comment: str = "") -> list[str]:
    lines = [f"{header}" + (f"  # {comment}" if comment else "")]
    lines += [f"{key} = {toml_value(value)}" for key, value in values.items() if value is not None]
    return lines + [""]


def _fields(struct: msgspec.Struct) -> dict[str, Any]:
    """A table's fields, nested tables (e.g. a vehicle's own sensor) left out."""
    return {key: value for key, value in msgspec.structs.asdict(struct).items() if not isinstance(value, msgspec.Struct)}


def scenario_text(name: str, description: str, source: SourceConfig, origin: tuple[float, float],
                  files: tuple[str, str | None], layout: CityLayout, defaults: Scenario) -> str:
    """The scenario file (module docstring); ``files`` are the buildings' and roads' GeoJSON names."""
    buildings_file, roads_file = files
    lines = [f"# {source.attribution}: derived from OpenStreetMap data, under the Open Database License",
             f"# ({source.licence_url}). Built by: {source.command}", "",
             f"name = {toml_value(name)}", f"description = {toml_value(description)}", ""]
    lines += _table("[source]", _fields(source), "where the city comes from, and its licence notice")
    lines += _table("[origin]", {"lat_deg": origin[0], "lon_deg": origin[1], "height_m": 0.0},
                    "OSM has no elevation: the ground is the ellipsoid")
    lines += _table("[time]", _fields(defaults.time))
    city = {"kind": "geojson", "geojson": buildings_file, "height_property": "height", "roads_geojson": roads_file,
            "roads_oneway_property": "oneway"}
    lines += _table("[city]", city, "footprints and roads beside this file, [lon, lat]")
    lines += _table("[sensor]", _fields(defaults.sensor), f"from {defaults.name}")
    lines += _vehicles(defaults, layout)
    lines += _target(defaults, layout)
    return "\n".join(lines).rstrip() + "\n"


def _vehicles(defaults: Scenario, layout: CityLayout) -> list[str]:
    default_centre = (0.5 * defaults.city.size_m[0], 0.5 * defaults.city.size_m[1])
    lowest = min(vehicle.altitude_m for vehicle in defaults.vehicles)
    lift = max(0.0, layout.tallest_roof_m + CLEARANCE_M - lowest)
    lines: list[str] = []
    for index, vehicle in enumerate(defaults.vehicles):
        values = _fields(vehicle)
        values["altitude_m"] = vehicle.altitude_m + lift
        values["start_enu_m"] = [round(layout.centre[axis] + vehicle.start_enu_m[axis] - default_centre[axis], 1)
                                 for axis in (0, 1)]
        comment = f"{defaults.name}'s UAVs, about the city centre" if index == 0 else ""
        lines += _table("[[vehicles]]", values, comment)
    return lines


def _target(defaults: Scenario, layout: CityLayout) -> list[str]:
    target = defaults.target
    if layout.target_start is None:
        values = _fields(target) | {"start_enu_m": list(layout.centre)}
        return _table("[target]", values, f"no roads in the box: {defaults.name}'s target")
    values = {"id": target.id, "motion": "streets", "start_enu_m": list(layout.target_start),
              "street_speed_mps": STREET_SPEED_MPS, "turn_probability": target.turn_probability,
              "max_speed_mps": target.max_speed_mps}
    return _table("[target]", values, "a car driving the streets, from the road point nearest the centre")
