"""Box buildings, the street grid of a generated city, and the two ways to get a city.

A building is a vertical prism: a footprint polygon (ENU metres, simple, stored
counter-clockwise, not necessarily convex) extruded from the ground ``z = 0`` to
its roof ``z = height``. This is the environment of wang2012 section 2.5 and the
3 km x 3 km, 400-building city of its section 5.

* :func:`generate_city` builds that city from a ``numpy.random.Generator``:
  a regular street grid with one axis-aligned box per block.
* :func:`buildings_from_geojson` reads footprints from an already-parsed GeoJSON
  FeatureCollection (the file is read by ``gcs.config.world``).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._geojson import features_with_parts
from gcs.core.world._polygons import as_ring, bboxes, inside_any, pad_edges, signed_area

__all__ = ["Buildings", "StreetGrid", "generate_city", "buildings_from_geojson"]


@dataclass(frozen=True, eq=False)
class Buildings:
    """Box buildings as padded arrays, ready for vectorised geometry.

    Build with :meth:`from_polygons`, :meth:`from_boxes` or :meth:`empty`; the
    arrays are read-only.

    Attributes
    ----------
    footprints : tuple of ndarray, each shape (k_b, 2)
        Footprint vertices, metres, counter-clockwise, no repeated closing vertex.
    heights : ndarray, shape (B,)
        Roof heights above the ground, metres, > 0.
    edges : ndarray, shape (B, E, 2, 2)
        ``edges[b, e] = [start, end]`` of footprint edge ``e``; padded to the
        longest footprint with zero-length edges (see ``edge_valid``).
    edge_valid : ndarray of bool, shape (B, E)
        False on padding edges.
    bbox : ndarray, shape (B, 4)
        ``xmin, ymin, xmax, ymax`` of each footprint, metres.
    convex : ndarray of bool, shape (B,)
        True for convex footprints (the visibility map uses them for upper bounds).
    """

    footprints: tuple[NDArray[np.float64], ...]
    heights: NDArray[np.float64]
    edges: NDArray[np.float64]
    edge_valid: NDArray[np.bool_]
    bbox: NDArray[np.float64]
    convex: NDArray[np.bool_]

    @classmethod
    def from_polygons(cls, polygons: Sequence[ArrayLike], heights: ArrayLike) -> Buildings:
        """Validate footprints and heights; clockwise footprints are reversed to CCW.

        Parameters
        ----------
        polygons : sequence of array_like, each shape (k, 2)
            Footprint vertices in ENU metres, k >= 3; a repeated closing vertex is dropped.
        heights : array_like, shape (B,)
            Roof heights, metres, finite and > 0.

        Raises
        ------
        ValueError
            Naming the polygon index: too few vertices, non-finite, zero area, bad height.
        """
        h = np.array(heights, dtype=np.float64).reshape(-1)
        if len(h) != len(polygons):
            raise ValueError(f"got {len(polygons)} polygons but {len(h)} heights")
        rings = []
        for index, polygon in enumerate(polygons):
            ring = as_ring(polygon, f"polygon {index}")
            if signed_area(ring) < 0.0:
                ring = ring[::-1].copy()
            if not (math.isfinite(h[index]) and h[index] > 0.0):
                raise ValueError(f"polygon {index}: height must be finite and > 0, got {h[index]!r}")
            rings.append(ring)
        return cls._build(rings, h)

    @classmethod
    def from_boxes(cls, boxes: ArrayLike, heights: ArrayLike) -> Buildings:
        """Axis-aligned box buildings from ``boxes (B, 4) = xmin, ymin, xmax, ymax`` and heights (B,)."""
        b = np.array(boxes, dtype=np.float64).reshape(-1, 4)
        x0, y0, x1, y1 = b.T
        corners = np.stack([np.stack([x0, y0], -1), np.stack([x1, y0], -1),
                            np.stack([x1, y1], -1), np.stack([x0, y1], -1)], axis=1)
        if not np.all((x1 > x0) & (y1 > y0)):
            raise ValueError("boxes need xmin < xmax and ymin < ymax")
        return cls.from_polygons(list(corners), heights)

    @classmethod
    def empty(cls) -> Buildings:
        """No buildings."""
        return cls._build([], np.zeros(0))

    @classmethod
    def _build(cls, rings: list[NDArray[np.float64]], heights: NDArray[np.float64]) -> Buildings:
        edges, valid = pad_edges(rings)
        convex = np.array([_is_convex(r) for r in rings], dtype=bool)
        arrays = (heights, edges, valid, bboxes(edges), convex, *rings)
        for array in arrays:
            array.flags.writeable = False
        return cls(tuple(rings), heights, edges, valid, arrays[3], convex)

    def __len__(self) -> int:
        return len(self.footprints)

    def contains_xy(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Whether each point lies inside any footprint (even-odd rule).

        Parameters
        ----------
        points : array_like, shape (..., 2)
            ENU metres.

        Returns
        -------
        ndarray of bool, shape (...)
            Points exactly on a wall may count either way.
        """
        xy = np.asarray(points, dtype=np.float64)
        if xy.shape[-1:] != (2,):
            raise ValueError(f"points must have shape (..., 2), got {xy.shape}")
        flat = xy.reshape(-1, 2)
        inside = inside_any(flat[:, 0], flat[:, 1], self.bbox, self.edges)
        return inside.reshape(xy.shape[:-1])


def _is_convex(ring: NDArray[np.float64]) -> bool:
    """True when every turn of a CCW ring is a left turn (or straight)."""
    d = np.roll(ring, -1, axis=0) - ring
    turn = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    return bool(np.all(turn >= 0.0))


@dataclass(frozen=True, eq=False)
class StreetGrid:
    """Centre lines of a generated city's streets.

    Attributes
    ----------
    xs : ndarray, shape (nx + 1,)
        Sorted x of the north-south streets, metres (0 and the city width included).
    ys : ndarray, shape (ny + 1,)
        Sorted y of the east-west streets, metres.
    width_m : float
        Street width, metres (a street covers centre +- width_m / 2).
    size_m : tuple of float
        City width (east) and depth (north), metres.
    """

    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    width_m: float
    size_m: tuple[float, float]

    def nearest_intersection(self, xy: ArrayLike) -> NDArray[np.float64]:
        """The street crossing nearest to each point: (..., 2) -> (..., 2), metres."""
        p = np.asarray(xy, dtype=np.float64)
        return np.stack([_nearest(self.xs, p[..., 0]), _nearest(self.ys, p[..., 1])], axis=-1)

    def on_street(self, xy: ArrayLike) -> NDArray[np.bool_]:
        """Whether each point (..., 2) lies on a street (closed strips, inside the city's street grid)."""
        p = np.asarray(xy, dtype=np.float64)
        x, y = p[..., 0], p[..., 1]
        half = 0.5 * self.width_m
        in_grid = (x >= self.xs[0] - half) & (x <= self.xs[-1] + half) \
            & (y >= self.ys[0] - half) & (y <= self.ys[-1] + half)
        near_x = np.abs(x - _nearest(self.xs, x)) <= half
        near_y = np.abs(y - _nearest(self.ys, y)) <= half
        on_street: NDArray[np.bool_] = in_grid & (near_x | near_y)
        return on_street


def _nearest(sorted_values: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """The element of a sorted array nearest to each value (ties go to the lower one)."""
    i = np.clip(np.searchsorted(sorted_values, v), 1, len(sorted_values) - 1)
    lower, upper = sorted_values[i - 1], sorted_values[i]
    return np.where(np.abs(v - lower) <= np.abs(upper - v), lower, upper)


_MIN_BLOCK_M = 1.0
"""Smallest block interior (between street edges) a generated grid may have, metres."""


def generate_city(
    rng: np.random.Generator,
    size_m: tuple[float, float] = (3000.0, 3000.0),
    buildings: int = 400,
    street_width_m: float = 30.0,
    min_height_m: float = 20.0,
    max_height_m: float = 120.0,
) -> tuple[Buildings, StreetGrid]:
    """A Manhattan-grid city like wang2012 section 5 (3 km x 3 km, 400 buildings).

    The ``size_m`` rectangle (south-west corner at the ENU origin) is cut into
    ``nx x ny`` equal blocks, nearly square, with ``nx * ny >= buildings``
    (20 x 20 for 400 buildings on a square city); a street of ``street_width_m``
    runs along every block boundary, the city's edges included. Each block's
    interior is split into lots only when there are more buildings than blocks
    that fit (block interior >= 1 m). Each used lot holds one axis-aligned box
    whose sides are uniform in [50 %, 100 %) of the lot and whose position in
    the lot is uniform, so no building reaches into a street; when there are
    more lots than buildings a uniformly chosen set of lots stays empty.
    Heights are uniform in (min_height_m, max_height_m].

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness; equal seeds give equal cities.
    size_m : (float, float)
        City width (east) and depth (north), metres.
    buildings : int
        Number of buildings, >= 0.
    street_width_m : float
        Street width, metres, >= 0.
    min_height_m, max_height_m : float
        Height range, metres, 0 <= min <= max, max > 0.

    Returns
    -------
    (Buildings, StreetGrid)
    """
    width, depth = float(size_m[0]), float(size_m[1])
    if not (width > 0.0 and depth > 0.0 and math.isfinite(width) and math.isfinite(depth)):
        raise ValueError(f"size_m must be two finite positive numbers, got {size_m!r}")
    if buildings < 0:
        raise ValueError(f"buildings must be >= 0, got {buildings}")
    if not street_width_m >= 0.0:
        raise ValueError(f"street_width_m must be >= 0, got {street_width_m}")
    if not (0.0 <= min_height_m <= max_height_m and max_height_m > 0.0):
        raise ValueError(f"need 0 <= min_height_m <= max_height_m and max_height_m > 0, "
                         f"got {min_height_m}, {max_height_m}")
    wanted = max(buildings, 1)
    nx = max(1, math.ceil(math.sqrt(wanted * width / depth)))
    ny = max(1, math.ceil(wanted / nx))
    fit_x = math.floor(width / (street_width_m + _MIN_BLOCK_M))
    fit_y = math.floor(depth / (street_width_m + _MIN_BLOCK_M))
    if fit_x < 1 or fit_y < 1:
        raise ValueError(f"street_width_m = {street_width_m} leaves no room for blocks in a {width} x {depth} m city")
    nx, ny = min(nx, fit_x), min(ny, fit_y)
    xs, ys = np.linspace(0.0, width, nx + 1), np.linspace(0.0, depth, ny + 1)
    half = 0.5 * street_width_m
    block_w, block_d = width / nx - street_width_m, depth / ny - street_width_m
    per_block = math.ceil(wanted / (nx * ny))
    lx = max(1, math.ceil(math.sqrt(per_block * block_w / block_d)))
    ly = math.ceil(per_block / lx)
    lot_w, lot_d = block_w / lx, block_d / ly
    # Lot index -> (block column, block row, lot column, lot row).
    lots = rng.choice(nx * ny * lx * ly, size=buildings, replace=False)
    lots.sort()
    block, lot = np.divmod(lots, lx * ly)
    bx, by = np.divmod(block, ny)
    lot_x, lot_y = np.divmod(lot, ly)
    x_lot = xs[bx] + half + lot_x * lot_w
    y_lot = ys[by] + half + lot_y * lot_d
    fraction = rng.uniform(0.5, 1.0, size=(buildings, 2))
    offset = rng.random(size=(buildings, 2))
    heights = max_height_m - (max_height_m - min_height_m) * rng.random(size=buildings)
    w, d = fraction[:, 0] * lot_w, fraction[:, 1] * lot_d
    x0 = x_lot + offset[:, 0] * (lot_w - w)
    y0 = y_lot + offset[:, 1] * (lot_d - d)
    boxes = np.stack([x0, y0, np.minimum(x0 + w, x_lot + lot_w), np.minimum(y0 + d, y_lot + lot_d)], axis=1)
    city = Buildings.from_boxes(boxes, heights) if buildings else Buildings.empty()
    xs.flags.writeable = ys.flags.writeable = False
    return city, StreetGrid(xs, ys, float(street_width_m), (width, depth))


def buildings_from_geojson(
    obj: Mapping[str, Any],
    height_property: str = "height",
    to_enu: Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[ArrayLike, ArrayLike]] | None = None,
) -> Buildings:
    """Buildings from a parsed GeoJSON FeatureCollection of footprints.

    Every feature must be a ``Polygon`` or ``MultiPolygon`` with a numeric,
    positive ``properties[height_property]`` in metres. Only the **outer ring**
    of each polygon is used: holes (inner rings, e.g. courtyards) are ignored,
    so a building with a courtyard is treated as solid, which can only hide a
    target, never reveal one. Each polygon of a MultiPolygon becomes one
    building with the feature's height.

    Parameters
    ----------
    obj : mapping
        The parsed FeatureCollection (``json.load`` output).
    height_property : str
        Name of the property holding the roof height, metres.
    to_enu : callable, optional
        ``to_enu(lon_deg, lat_deg) -> (x, y)`` on arrays, applied to every
        ring. Without it, coordinates are taken as ENU metres ``[x, y]``.

    Raises
    ------
    ValueError
        Naming the feature index and the problem.
    """
    rings: list[NDArray[np.float64]] = []
    heights: list[float] = []
    for where, feature, parts in features_with_parts(obj, "Polygon", "MultiPolygon", "polygon"):
        height = _feature_height(feature, height_property, where)
        for label, polygon in parts:
            if not isinstance(polygon, list) or not polygon:
                raise ValueError(f"{label}: no rings")
            rings.append(_outer_ring(polygon[0], label, to_enu))
            heights.append(height)
    return Buildings.from_polygons(rings, heights) if rings else Buildings.empty()


def _feature_height(feature: Mapping[str, Any], height_property: str, where: str) -> float:
    properties = feature.get("properties")
    if not isinstance(properties, Mapping) or height_property not in properties:
        raise ValueError(f"{where}: missing property {height_property!r} (roof height, metres)")
    value = properties[height_property]
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{where}: property {height_property!r} must be a number, got {value!r}")
    height = float(value)
    if not (math.isfinite(height) and height > 0):
        raise ValueError(f"{where}: property {height_property!r} must be finite and > 0, got {value!r}")
    return height


def _outer_ring(
    ring: Any,
    where: str,
    to_enu: Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[ArrayLike, ArrayLike]] | None,
) -> NDArray[np.float64]:
    try:
        points = np.array(ring, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: coordinates must be [x, y] number pairs") from None
    if points.ndim != 2 or points.shape[1] < 2:
        raise ValueError(f"{where}: coordinates must be [x, y] number pairs")
    points = points[:, :2]
    if to_enu is not None:
        x, y = to_enu(points[:, 0], points[:, 1])
        points = np.stack([np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)], axis=-1)
    return as_ring(points, where)
