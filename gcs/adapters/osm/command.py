"""``gcs scenario from-osm FILE --bbox W,S,E,N --out city.toml``: a scenario from an OpenStreetMap extract.

This module holds the command line alone (light: the ``scenario`` command's
parser imports it, and it imports only the standard library's modules); the
work, and pyosmium, are imported when the command runs
(:mod:`gcs.adapters.osm.importer`). Bad input is one line and exit status 2:
a missing file, a box that is not four numbers, out of range or in the wrong
order, a box beyond the file's data or with nothing in it, a scenario name that
is not one, and pyosmium not installed.
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

from gcs.adapters.osm.clipping import box_text
from gcs.adapters.osm.heights import DEFAULT_HEIGHT_M
from gcs.cli_errors import UsageError, existing_file, positive, set_command, writable_file

__all__ = ["add_from_osm", "parse_box", "parse_origin", "recorded_command"]

HELP = "build a scenario from an OpenStreetMap extract (.osm.pbf or .osm): buildings, roads, a car on them"
NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


def add_from_osm(actions: argparse._SubParsersAction) -> None:
    """Register ``from-osm`` under ``gcs scenario``."""
    parser = actions.add_parser(
        "from-osm", help=HELP,
        description="Build a scenario from an OpenStreetMap extract: the buildings whose centre lies in the box "
                    "(heights from height, building:levels x 3 m, or a default), the drivable roads cut to the box, "
                    "a car that drives them, and the default scenario's UAVs and sensors. Writes OUT and "
                    "OUT_buildings.geojson / OUT_roads.geojson beside it, with the OpenStreetMap attribution "
                    "(ODbL) recorded in them. Needs pyosmium: pip install 'uav-tracking-gcs[osm]'.")
    parser.add_argument("source", type=Path, metavar="FILE", help="the extract: .osm.pbf, or .osm XML")
    parser.add_argument("--bbox", required=True, metavar="W,S,E,N",
                        help="the box, degrees: west, south, east, north (west of Greenwich write --bbox=-0.2,...)")
    parser.add_argument("--out", required=True, type=Path, metavar="OUT.toml",
                        help="the scenario file to write; its name (letters, digits, _ and -) is the scenario's")
    parser.add_argument("--origin", metavar="LAT,LON",
                        help="geodetic origin of the ENU frame, degrees (default: the box's centre)")
    parser.add_argument("--default-height", type=float, default=DEFAULT_HEIGHT_M, metavar="M",
                        help=f"roof height of a building with neither height nor building:levels, metres "
                             f"(default {DEFAULT_HEIGHT_M:g})")
    parser.add_argument("--description", help="the scenario's description (default: its figures and source)")
    set_command(parser, _run, _check)


def parse_box(text: str) -> tuple[float, float, float, float]:
    """``W,S,E,N`` in degrees, checked: four numbers, longitudes in [-180, 180], latitudes in [-90, 90], west <
    east and south < north; else :class:`UsageError` naming the value."""
    values = _numbers(text, 4, "--bbox", "four numbers W,S,E,N (degrees: west, south, east, north)")
    west, south, east, north = values
    for name, value, limit in (("west", west, 180.0), ("south", south, 90.0), ("east", east, 180.0),
                               ("north", north, 90.0)):
        if not -limit <= value <= limit:
            raise UsageError(f"--bbox {text}: {name} = {value:g} is outside [-{limit:g}, {limit:g}] degrees")
    if not (west < east and south < north):
        raise UsageError(f"--bbox {text}: needs west < east and south < north (the order is W,S,E,N)")
    return west, south, east, north


def parse_origin(text: str) -> tuple[float, float]:
    """``LAT,LON`` in degrees, in range; else :class:`UsageError`."""
    lat, lon = _numbers(text, 2, "--origin", "two numbers LAT,LON (degrees)")
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise UsageError(f"--origin {text}: latitude must be in [-90, 90] and longitude in [-180, 180] degrees")
    return lat, lon


def _numbers(text: str, count: int, option: str, expected: str) -> tuple[float, ...]:
    parts = [part.strip() for part in text.split(",")]
    try:
        values = tuple(float(part) for part in parts)
    except ValueError:
        values = ()
    if len(values) != count or not all(abs(v) < float("inf") for v in values):
        raise UsageError(f"{option} {text}: give {expected}")
    return values


def _check(args: argparse.Namespace) -> None:
    existing_file(args.source, "FILE")
    args.box = parse_box(args.bbox)
    args.origin_lat_lon = parse_origin(args.origin) if args.origin else None
    positive(args.default_height, "--default-height")
    if args.out.suffix != ".toml":
        raise UsageError(f"--out {args.out}: give a .toml file name")
    if not NAME.match(args.out.stem):
        raise UsageError(f"--out {args.out}: the file's name is the scenario's: letters, digits, _ and - only")
    writable_file(args.out, "--out")


def recorded_command(args: argparse.Namespace) -> str:
    """The command line as the scenario records it: the file names without their folders, the box's digits."""
    words = ["gcs", "scenario", "from-osm", args.source.name, f"--bbox={box_text(args.box)}"]
    if args.origin_lat_lon is not None:
        words.append("--origin=" + ",".join(repr(v) for v in args.origin_lat_lon))
    if args.default_height != DEFAULT_HEIGHT_M:
        words += ["--default-height", repr(args.default_height)]
    if args.description:
        words += ["--description", args.description]
    return shlex.join(words + ["--out", args.out.name])


def _run(args: argparse.Namespace) -> int:
    _check(args)
    from gcs.adapters.osm.importer import OsmBoxError, OsmRequest, build_osm_scenario
    from gcs.adapters.osm.reading import OsmReadError, OsmUnavailable

    request = OsmRequest(args.source, args.box, args.out, args.origin_lat_lon, args.default_height, args.description,
                         recorded_command(args))
    try:
        city = build_osm_scenario(request)
    except (OsmUnavailable, OsmReadError, OsmBoxError) as exc:
        raise UsageError(str(exc)) from None
    median = city.tagged_median_m
    print(f"wrote {city.scenario}, {city.buildings_file.name}" + (f", {city.roads_file.name}" if city.roads_file else ""))
    print(f"buildings: {len(city.buildings)} (height from height: {city.count('height')}, from building:levels: "
          f"{city.count('building:levels')}, default {args.default_height:g} m: {city.count('default')}); "
          f"median tagged height: " + ("-" if median is None else f"{median:g} m"))
    print(f"roads: {len(city.roads.edges)} junction-to-junction edges, {city.roads.length_m / 1000.0:.1f} km, "
          f"{sum(edge.oneway for edge in city.roads.edges)} one-way; {city.roads.junctions - city.roads.junctions_dropped} "
          f"of {city.roads.junctions} junctions strongly connected")
    print(f"data: {args.source.name}" + (f" of {city.data_date}" if city.data_date else "")
          + " © OpenStreetMap contributors, ODbL 1.0: the scenario and its GeoJSON are derived data under the ODbL")
    return 0
