"""The ``[city]`` table (buildings and roads) and the ``[source]`` table (where a city's data came from).

A generated city is a ``size_m`` rectangle whose south-west corner is the ENU
origin. A city read from files (GeoJSON buildings, GeoJSON roads) lies wherever
its coordinates put it: its world is framed on its content
(:func:`gcs.config.world.build_world`), and ``size_m`` does not apply to it.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec

from gcs.config.base import Config as _Config
from gcs.config.base import NonNegative, Positive

__all__ = ["CityConfig", "SourceConfig"]


class CityConfig(_Config, frozen=True):
    """Box buildings: generated from a seed, or read from a GeoJSON file of footprints.

    ``kind = "generated"``: ``buildings`` boxes in a ``size_m`` rectangle whose
    south-west corner is ``(0, 0)`` in ENU, streets of ``street_width_m`` between
    blocks, heights uniform in [``min_height_m``, ``max_height_m``].
    ``kind = "geojson"``: polygons from ``geojson`` (a path relative to the
    scenario file) with a ``height_property`` in metres.
    ``roads_geojson``: the drivable roads as GeoJSON LineStrings (any kind).
    """

    kind: Literal["generated", "geojson", "empty"] = "generated"
    size_m: tuple[Positive, Positive] = (3000.0, 3000.0)
    """A generated city's rectangle (and an empty city's without roads); a city read from files is framed on
    its content instead (:attr:`framed_on_content`)."""
    buildings: Annotated[int, msgspec.Meta(ge=0, le=100_000)] = 400
    seed: Annotated[int, msgspec.Meta(ge=0)] = 0
    street_width_m: NonNegative = 20.0
    min_height_m: NonNegative = 10.0
    max_height_m: NonNegative = 100.0
    geojson: str | None = None
    height_property: str = "height"
    roads_geojson: str | None = None
    """The road network: a GeoJSON file of LineStrings (relative to the scenario file), any ``kind``;
    a generated city without it drives its street grid."""
    roads_oneway_property: str = "oneway"
    """The ``roads_geojson`` property that marks a one-way road (true, "yes", or "-1" against the drawing)."""

    @property
    def framed_on_content(self) -> bool:
        """Whether the world's extent comes from the city's buildings and roads (a GeoJSON city, or an empty
        one with roads) rather than from the ``size_m`` rectangle."""
        return self.kind == "geojson" or (self.kind == "empty" and self.roads_geojson is not None)


class SourceConfig(_Config, frozen=True):
    """Where a scenario's city data came from, and the notice its licence asks for (``[source]``).

    A city built from OpenStreetMap (``gcs scenario from-osm``) is derived data
    under the Open Database License: the scenario and its GeoJSON files carry
    ``attribution`` and ``licence``, and say which extract (``file``, its
    ``sha256`` and ``data_date``) and which ``command`` made them.
    """

    attribution: str
    """The notice to show with the data, e.g. "© OpenStreetMap contributors"."""
    licence: str = ""
    """SPDX identifier of the data's licence, e.g. "ODbL-1.0"."""
    licence_url: str = ""
    file: str = ""
    """The source file's name (no folder)."""
    sha256: str = ""
    """SHA-256 of the source file, hex."""
    data_date: str = ""
    """How recent the data is, as the source states it (e.g. its newest element's timestamp); "" if unknown."""
    command: str = ""
    """The command line that built the scenario from the source."""
