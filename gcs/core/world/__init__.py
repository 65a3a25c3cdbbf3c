"""The city: box buildings, line of sight, visibility regions and restricted airspace.

wang2012 section 2.5 (environment model) and section 5 (the 3 km x 3 km,
400-building city). Frames: local ENU metres, x east, y north, z up, the
ground at z = 0, a generated city's south-west corner at (0, 0).

* :class:`Buildings`, :func:`generate_city`, :func:`buildings_from_geojson`,
  :class:`StreetGrid` -- :mod:`gcs.core.world.buildings`
* :func:`line_of_sight` (exact), :class:`VisibilityMap` / :func:`visibility_maps`
  (X^{hV}, fast and identical), :class:`VisibilityMaps` (several at once) --
  :mod:`gcs.core.world.los`
* :class:`SightTable` (where a ground point is seen from, on a height grid,
  for the sight planner) -- :mod:`gcs.core.world.sight_table`
* :class:`RestrictedAirspace` (eq. 5) -- :mod:`gcs.core.world.airspace`
* the road network (:class:`gcs.core.roads.RoadGraph`), when the city has one;
* the world's extent (:data:`Bounds`: a generated city's rectangle, or a real
  city's content with a margin) -- :mod:`gcs.core.world.extent`;
* :class:`World` bundles them; ``gcs.config.world.build_world`` makes one
  from a scenario.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world.airspace import RestrictedAirspace
from gcs.core.world.sight_table import HeightField, SightTable
from gcs.core.world.buildings import Buildings, StreetGrid, buildings_from_geojson, generate_city
from gcs.core.world.extent import FRAME_MARGIN_M, Bounds, content_bounds, rectangle_bounds
from gcs.core.world.los import (
    DEFAULT_BINS,
    SightLines,
    VisibilityMap,
    VisibilityMaps,
    line_of_sight,
    visibility_map,
    visibility_maps,
)

if TYPE_CHECKING:
    from gcs.core.roads.graph import RoadGraph

__all__ = [
    "World",
    "Bounds",
    "FRAME_MARGIN_M",
    "content_bounds",
    "rectangle_bounds",
    "Buildings",
    "StreetGrid",
    "RestrictedAirspace",
    "HeightField",
    "SightTable",
    "SightLines",
    "VisibilityMap",
    "VisibilityMaps",
    "DEFAULT_BINS",
    "generate_city",
    "buildings_from_geojson",
    "line_of_sight",
    "visibility_map",
    "visibility_maps",
]


@dataclass(frozen=True, eq=False, init=False)
class World:
    """Everything the planner and the simulator know about the environment.

    Attributes
    ----------
    buildings : Buildings
    airspace : RestrictedAirspace
    streets : StreetGrid or None
        The street grid of a generated city; None for GeoJSON or empty cities.
    size_m : tuple of float
        Width (east) and depth (north) of the world's extent, metres: a generated city's
        rectangle from (0, 0); for a world given ``bounds_m``, their width and depth.
    roads : RoadGraph or None
        The drivable roads (:mod:`gcs.core.roads`): a generated city's street grid, or
        the scenario's declared roads; None where the world has none.
    bounds_m : tuple of float
        The extent, ``x_min, y_min, x_max, y_max`` metres (:mod:`gcs.core.world.extent`): what
        the maps draw and frame, and the ground a free-driving target keeps to. Default: the
        ``size_m`` rectangle from (0, 0).
    """

    buildings: Buildings
    airspace: RestrictedAirspace
    streets: StreetGrid | None
    size_m: tuple[float, float]
    roads: RoadGraph | None
    bounds_m: Bounds
    _sight_tables: dict[tuple[float, float, float], SightTable] = field(init=False, repr=False)

    def __init__(self, buildings: Buildings, airspace: RestrictedAirspace, streets: StreetGrid | None,
                 size_m: tuple[float, float], roads: RoadGraph | None = None, bounds_m: Bounds | None = None) -> None:
        if bounds_m is None:
            bounds_m = rectangle_bounds(size_m)
        else:
            x0, y0, x1, y1 = (float(v) for v in bounds_m)
            if not (x0 < x1 and y0 < y1):
                raise ValueError(f"bounds_m must be x_min < x_max, y_min < y_max, got {bounds_m!r}")
            bounds_m, size_m = (x0, y0, x1, y1), (x1 - x0, y1 - y0)
        for name, value in (("buildings", buildings), ("airspace", airspace), ("streets", streets),
                            ("size_m", size_m), ("roads", roads), ("bounds_m", bounds_m), ("_sight_tables", {})):
            object.__setattr__(self, name, value)

    def inside(self, xy: ArrayLike) -> NDArray[np.bool_]:
        """Whether ground points (..., 2) lie within :attr:`bounds_m` (edges included)."""
        p = np.asarray(xy, dtype=np.float64)
        x0, y0, x1, y1 = self.bounds_m
        return (p[..., 0] >= x0) & (p[..., 0] <= x1) & (p[..., 1] >= y0) & (p[..., 1] <= y1)

    @classmethod
    def empty(cls, size_m: tuple[float, float] = (3000.0, 3000.0)) -> World:
        """Open ground: no buildings, no restricted airspace."""
        return cls(Buildings.empty(), RestrictedAirspace.empty(), None, (float(size_m[0]), float(size_m[1])))

    def line_of_sight(self, a_xyz: ArrayLike, b_xyz: ArrayLike) -> NDArray[np.bool_]:
        """:func:`line_of_sight` against this world's buildings; (..., 3) x (..., 3) -> (...)."""
        return line_of_sight(self.buildings, a_xyz, b_xyz)

    def visibility_map(
        self, target_xy: ArrayLike, altitude_m: float, max_range_m: float,
        target_height_m: float = 0.0, bins: int = DEFAULT_BINS,
    ) -> VisibilityMap:
        """:func:`visibility_map` of one target point at one altitude."""
        return visibility_map(self.buildings, target_xy, altitude_m, max_range_m, target_height_m, bins)

    def visibility_maps(
        self, target_xys: ArrayLike, altitude_m: float, max_range_m: float,
        target_height_m: float = 0.0, bins: int = DEFAULT_BINS,
    ) -> tuple[VisibilityMap, ...]:
        """One :class:`VisibilityMap` per predicted target point ``(n, 2)``."""
        return visibility_maps(self.buildings, target_xys, altitude_m, max_range_m, target_height_m, bins)

    def sight_lines(self, target_xys: ArrayLike, altitude_m: float, max_range_m: float,
                    target_height_m: float = 0.0) -> SightLines:
        """:class:`SightLines` of predicted target points ``(n, 2)``: the maps' answers, without the maps."""
        return SightLines(self.buildings, target_xys, altitude_m, max_range_m, target_height_m)

    def sight_table(self, reference_altitude_m: float, target_height_m: float = 0.0,
                    reach_m: float = 600.0) -> SightTable:
        """The :class:`SightTable` of this city for vehicles at or above ``reference_altitude_m``.

        One per (altitude, target height), kept: its tables are memoised, and every
        planner built on this world shares them.
        """
        key = (float(reference_altitude_m), float(target_height_m), float(reach_m))
        table = self._sight_tables.get(key)
        if table is None:
            table = self._sight_tables[key] = SightTable(self._height_field, key[0], key[1], reach_m=key[2])
        return table

    @cached_property
    def _height_field(self) -> HeightField:
        """The buildings' heights on a grid, which every :class:`SightTable` of this world shares."""
        return HeightField.from_buildings(self.buildings)

    def in_restricted(self, xyz: ArrayLike) -> NDArray[np.bool_]:
        """Whether points (..., 3) are in restricted airspace (wang2012 eq. 5, 26)."""
        return self.airspace.inside(xyz)
