"""Precomputed visibility region of one target point at one vehicle altitude.

wang2012 section 2.5 replaces "can UAV i see the target?" by "is UAV i inside
the target's visibility region X^{hV}(x) at its altitude h?", which the RHC
cost tests for every chromosome, vehicle and horizon step (eq. 22). A
:class:`VisibilityMap` answers that test for any number of horizontal vehicle
positions, with exactly the answers of
``line_of_sight(buildings, [tx, ty, z_t], [vx, vy, h])`` combined with the
sensor range ``|vehicle - target| <= max_range_m`` (3-D distance).

The region is star-shaped about the target. Along the ray from the target at
azimuth theta (from east, counter-clockwise), a building whose footprint the
ray first enters at horizontal distance ``s1`` and whose roof is at ``H``
blocks a vehicle at horizontal distance ``D`` iff ``s1 < D`` and the sight line
is still below the roof at the entry point, ``z_t + (h - z_t) s1 / D < H``
(the sight line rises monotonically, so its lowest point over the footprint is
the entry point). Hence the visible distance along theta is

.. math::
    v(\\theta) = \\min_b s_{1,b}(\\theta)\\,\\max\\big(1, (h - z_t) / (H_b - z_t)\\big),

buildings with ``H_b <= z_t`` never block, and ``X^{hV} = {D <= v(theta)}``
within range.

How the map stays exact: the circle is cut into ``bins`` equal angular
sectors. For each sector and each building that can reach it, the build
computes

* a lower bound on ``s1 * factor`` over the sector: the distance from the
  target to the footprint's part inside the sector (from the entry points of
  the two boundary rays and the footprint's vertices and nearest edge points
  inside the sector);
* for a convex footprint crossed by both boundary rays, an upper bound: the
  larger of the two entry distances (the segment between the two entry points
  lies in the footprint, and every ray of the sector crosses it).

Sectors are widened by 1e-6 rad for both, so that a query whose azimuth
rounds into a sector from just outside, or runs exactly along a wall, is
still covered. A query nearer than every lower bound is visible, one farther
than an upper bound is hidden -- each with a margin of 1e-9 relative plus
1e-6 m, far above rounding error; the queries in between are decided by the
same exact (segment, building) function ``line_of_sight`` uses
(:func:`gcs.core.world._kernel.combos_blocked`) on the sector's candidate
buildings only (buildings whose lower bound exceeds the sector's upper bound
cannot be the first to block and are dropped). A building within 1 mm of the
target may graze any sight line within rounding error, so it makes every
query of the map go through the exact test (slower, still exact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._kernel import canonical_order, combos_blocked
from gcs.core.world.buildings import Buildings

__all__ = ["DEFAULT_BINS", "VisibilityMap", "VisibilityMaps", "visibility_map", "visibility_maps"]

DEFAULT_BINS = 1024
"""Default number of angular sectors."""

_ANGLE_MARGIN = 1e-6
"""Radians by which building extents and vertex sectors are widened."""
_TOUCH_M = 1e-3
"""Buildings this close to the target are candidates in every sector and allow no shortcut."""
_REL_MARGIN = 1e-9
_ABS_MARGIN_M = 1e-6
"""Decided-without-the-exact-test queries clear their bound by this much, relative plus absolute."""
_MIN_CHORD_M = 1e-6
"""A boundary ray must cross a footprint by this much for the footprint to give an upper bound."""


@dataclass(frozen=True, eq=False)
class VisibilityMap:
    """Visibility region X^{hV} of one target point at one vehicle altitude (wang2012 sec. 2.5).

    Build with :func:`visibility_map`.

    Attributes
    ----------
    buildings : Buildings
    target_xyz : ndarray, shape (3,)
        Target point, ENU metres (``z`` is ``target_height_m``).
    altitude_m : float
        Vehicle altitude ``h``, metres, above the target point.
    max_range_m : float
        Sensor range (3-D distance), metres.
    bins : int
        Number of angular sectors; sector ``k`` covers azimuths
        ``[-pi + k 2pi/bins, -pi + (k + 1) 2pi/bins)``.
    near_m : ndarray, shape (bins,)
        Horizontal distances below which every query in the sector is visible.
    far_m : ndarray, shape (bins,)
        Horizontal distances above which every query in the sector is hidden.
    candidates : ndarray of int, shape (bins, K)
        Buildings that may decide the queries in between; -1 is padding.
    """

    buildings: Buildings
    target_xyz: NDArray[np.float64]
    altitude_m: float
    max_range_m: float
    bins: int
    near_m: NDArray[np.float64]
    far_m: NDArray[np.float64]
    candidates: NDArray[np.intp]

    @property
    def horizontal_range_m(self) -> float:
        """Largest horizontal distance within sensor range at this altitude, metres."""
        dz = self.altitude_m - float(self.target_xyz[2])
        return math.sqrt(max(self.max_range_m**2 - dz * dz, 0.0))

    def _sector(self, theta: NDArray[np.float64]) -> NDArray[np.intp]:
        return _sector(theta, self.bins)

    def visible(self, vehicle_xy: ArrayLike) -> NDArray[np.bool_]:
        """Whether a vehicle at each horizontal position, at ``altitude_m``, sees the target.

        Parameters
        ----------
        vehicle_xy : array_like, shape (..., 2)
            ENU metres.

        Returns
        -------
        ndarray of bool, shape (...)
            Exactly ``line_of_sight(buildings, target_xyz, [x, y, altitude_m])
            & (dx**2 + dy**2 + dz**2 <= max_range_m**2)``; False for
            non-finite positions.
        """
        xy = np.asarray(vehicle_xy, dtype=np.float64)
        if xy.shape[-1:] != (2,):
            raise ValueError(f"vehicle_xy must have shape (..., 2), got {xy.shape}")
        flat = xy.reshape(-1, 2)
        result = _answer(self.buildings, self.target_xyz[None], np.array([self.altitude_m]),
                         np.array([self.max_range_m]), self.bins, self.near_m, self.far_m, self.candidates,
                         flat, np.zeros(len(flat), dtype=np.intp))
        return result.reshape(xy.shape[:-1])

    def max_visible_range(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Horizontal extent of the visibility region along azimuths theta, metres.

        ``v(theta)`` of the module docstring, clipped to :attr:`horizontal_range_m`:
        vehicles at ``altitude_m`` nearer than this along theta see the target,
        farther ones do not. For plotting the visibility polygon
        ``target_xy + v(theta) (cos theta, sin theta)``.

        Parameters
        ----------
        theta : array_like, shape (...)
            Azimuths, radians from east, counter-clockwise.
        """
        angles = np.asarray(theta, dtype=np.float64)
        flat = angles.reshape(-1)
        limit = np.full(len(flat), self.horizontal_range_m)
        rows = self.candidates[self._sector(flat)]
        ray, slot = np.nonzero(rows >= 0)
        if len(ray):
            index = rows[ray, slot]
            tx, ty, tz = self.target_xyz
            rel = _relative_edges(self.buildings.edges, tx, ty).take(index, axis=2)
            entry, _ = _cast(np.cos(flat[ray]), np.sin(flat[ray]), rel)
            reach = entry * _factor(self.buildings.heights[index], tz, self.altitude_m)
            np.minimum.at(limit, ray, reach)
        return limit.reshape(angles.shape)


@dataclass(frozen=True, eq=False)
class VisibilityMaps:
    """Several visibility maps answered in one vectorised call, e.g. the k+1..k+n
    predicted target points of a receding horizon (wang2012 eq. 22).

    ``VisibilityMaps(visibility_maps(buildings, points, h, r))``. The maps must
    share the buildings (the same object) and the number of sectors; target
    points, altitudes and ranges may differ.

    Parameters
    ----------
    maps : sequence of VisibilityMap
    """

    maps: tuple[VisibilityMap, ...]
    _targets: NDArray[np.float64] = field(init=False, repr=False)
    _altitudes: NDArray[np.float64] = field(init=False, repr=False)
    _ranges: NDArray[np.float64] = field(init=False, repr=False)
    _near: NDArray[np.float64] = field(init=False, repr=False)
    _far: NDArray[np.float64] = field(init=False, repr=False)
    _candidates: NDArray[np.intp] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        maps = tuple(self.maps)
        if not maps:
            raise ValueError("VisibilityMaps needs at least one map")
        if any(m.buildings is not maps[0].buildings or m.bins != maps[0].bins for m in maps):
            raise ValueError("all maps must share the same Buildings object and number of bins")
        width = max(m.candidates.shape[1] for m in maps)
        candidates = np.full((len(maps), maps[0].bins, width), -1, dtype=np.intp)
        for index, m in enumerate(maps):
            candidates[index, :, : m.candidates.shape[1]] = m.candidates
        stacked = {
            "_targets": np.stack([m.target_xyz for m in maps]),
            "_altitudes": np.array([m.altitude_m for m in maps]),
            "_ranges": np.array([m.max_range_m for m in maps]),
            "_near": np.concatenate([m.near_m for m in maps]),
            "_far": np.concatenate([m.far_m for m in maps]),
            "_candidates": candidates.reshape(len(maps) * maps[0].bins, width),  # width may be 0: no buildings
        }
        object.__setattr__(self, "maps", maps)
        for name, array in stacked.items():
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    def __len__(self) -> int:
        return len(self.maps)

    def __getitem__(self, index: int) -> VisibilityMap:
        return self.maps[index]

    def visible(self, vehicle_xy: ArrayLike) -> NDArray[np.bool_]:
        """Map ``i`` answers the positions ``vehicle_xy[..., i, :]``.

        Parameters
        ----------
        vehicle_xy : array_like, shape (..., n, 2)
            ENU metres; ``n = len(self)`` (e.g. population x vehicles x horizon x 2).

        Returns
        -------
        ndarray of bool, shape (..., n)
            ``self[i].visible(vehicle_xy[..., i, :])`` for every i, identically.
        """
        xy = np.asarray(vehicle_xy, dtype=np.float64)
        if xy.ndim < 2 or xy.shape[-2:] != (len(self.maps), 2):
            raise ValueError(f"vehicle_xy must have shape (..., {len(self.maps)}, 2), got {xy.shape}")
        flat = xy.reshape(-1, 2)
        which = np.tile(np.arange(len(self.maps)), len(flat) // len(self.maps))
        first = self.maps[0]
        result = _answer(first.buildings, self._targets, self._altitudes, self._ranges, first.bins,
                         self._near, self._far, self._candidates, flat, which)
        return result.reshape(xy.shape[:-1])


def _sector(theta: NDArray[np.float64], bins: int) -> NDArray[np.intp]:
    """Sector index of azimuths; non-finite azimuths go to the sector of azimuth 0."""
    theta = np.where(np.isfinite(theta), theta, 0.0)
    k = np.floor((theta + np.pi) * (bins / (2.0 * np.pi))).astype(np.intp)
    return np.mod(k, bins)


def _answer(
    buildings: Buildings,
    targets: NDArray[np.float64],
    altitudes: NDArray[np.float64],
    ranges: NDArray[np.float64],
    bins: int,
    near_m: NDArray[np.float64],
    far_m: NDArray[np.float64],
    candidates: NDArray[np.intp],
    xy: NDArray[np.float64],
    which: NDArray[np.intp],
) -> NDArray[np.bool_]:
    """Visibility of vehicles ``xy (N, 2)`` for map ``which (N,)``.

    ``targets (n, 3)``, ``altitudes (n,)``, ``ranges (n,)``; sector tables
    flattened over maps: ``near_m, far_m (n * bins,)``, ``candidates (n * bins, K)``.
    """
    target = targets[which]
    altitude = altitudes[which]
    dx, dy = xy[:, 0] - target[:, 0], xy[:, 1] - target[:, 1]
    dz = altitude - target[:, 2]
    horizontal2 = dx * dx + dy * dy
    in_range = horizontal2 + dz * dz <= ranges[which] * ranges[which]
    distance = np.sqrt(horizontal2)
    sector = which * bins + _sector(np.arctan2(dy, dx), bins)
    near = distance < near_m[sector]
    result = in_range & near
    open_ = np.flatnonzero(in_range & ~near & (distance <= far_m[sector]))
    if len(open_):
        rows = candidates[sector[open_]]
        query, slot = np.nonzero(rows >= 0)
        chosen = open_[query]
        vehicle = np.stack([xy[chosen, 0], xy[chosen, 1], altitude[chosen]], axis=1)
        p, q = canonical_order(target[chosen], vehicle)
        blocked = combos_blocked(buildings, p, q, rows[query, slot])
        result[open_] = np.bincount(query[blocked], minlength=len(open_)) == 0
    return result


def visibility_map(
    buildings: Buildings,
    target_xy: ArrayLike,
    altitude_m: float,
    max_range_m: float,
    target_height_m: float = 0.0,
    bins: int = DEFAULT_BINS,
) -> VisibilityMap:
    """Build the visibility region of one (predicted) target point at one altitude.

    Parameters
    ----------
    buildings : Buildings
    target_xy : array_like, shape (2,)
        Target position, ENU metres.
    altitude_m : float
        Vehicle altitude, metres; must be above ``target_height_m``.
    max_range_m : float
        Sensor range (3-D distance), metres, > 0.
    target_height_m : float
        Height of the observed point on the target, metres, >= 0.
    bins : int
        Angular sectors; more sectors cost more to build and less to query.
    """
    t = np.asarray(target_xy, dtype=np.float64)
    if t.shape != (2,) or not np.all(np.isfinite(t)):
        raise ValueError(f"target_xy must be two finite numbers, got {target_xy!r}")
    if not (math.isfinite(target_height_m) and target_height_m >= 0.0):
        raise ValueError(f"target_height_m must be finite and >= 0, got {target_height_m!r}")
    if not (math.isfinite(altitude_m) and altitude_m > target_height_m):
        raise ValueError(f"altitude_m must be finite and above target_height_m, got {altitude_m!r}")
    if not max_range_m > 0.0:
        raise ValueError(f"max_range_m must be > 0, got {max_range_m!r}")
    if int(bins) != bins or bins < 8:
        raise ValueError(f"bins must be an integer >= 8, got {bins!r}")
    bins = int(bins)
    target = np.array([t[0], t[1], float(target_height_m)])
    target.flags.writeable = False
    empty = VisibilityMap(buildings, target, float(altitude_m), float(max_range_m), bins,
                          np.full(bins, np.inf), np.full(bins, np.inf), np.full((bins, 0), -1, dtype=np.intp))
    reach_m = empty.horizontal_range_m
    if len(buildings) == 0 or reach_m == 0.0:
        return empty
    near, far, candidates = _sectors(buildings, target, float(altitude_m), reach_m, bins)
    return VisibilityMap(buildings, target, float(altitude_m), float(max_range_m), bins, near, far, candidates)


def visibility_maps(
    buildings: Buildings,
    target_xys: ArrayLike,
    altitude_m: float,
    max_range_m: float,
    target_height_m: float = 0.0,
    bins: int = DEFAULT_BINS,
) -> tuple[VisibilityMap, ...]:
    """One :func:`visibility_map` per predicted target point, ``target_xys (n, 2)`` (e.g. k+1..k+n).

    Wrap the result in :class:`VisibilityMaps` to answer all of them in one call.
    """
    points = np.asarray(target_xys, dtype=np.float64).reshape(-1, 2)
    return tuple(visibility_map(buildings, p, altitude_m, max_range_m, target_height_m, bins) for p in points)


def _factor(heights: NDArray[np.float64], tz: float, altitude_m: float) -> NDArray[np.float64]:
    """max(1, (h - z_t) / (H - z_t)): how far past its entry point a building still hides the target."""
    with np.errstate(divide="ignore"):
        return np.where(heights > tz, np.maximum(1.0, (altitude_m - tz) / (heights - tz)), np.inf)


def _relative_edges(edges: NDArray[np.float64], ox: float, oy: float) -> NDArray[np.float64]:
    """Edges (n, E, 2, 2) relative to (ox, oy) as one contiguous array (4, E, n): x0, y0, x1, y1."""
    rel = edges.transpose(2, 3, 1, 0) - np.array([ox, oy])[None, :, None, None]
    return np.ascontiguousarray(rel.reshape(4, edges.shape[1], edges.shape[0]))


def _cast(
    ux: NDArray[np.float64], uy: NDArray[np.float64], rel: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rays from the origin along unit vectors (ux, uy) (R,), each against one footprint.

    ``rel`` (4, E, R) holds each ray's footprint edges relative to the ray's
    origin (:func:`_relative_edges`), edge-major so reductions run over the
    leading axis.

    Returns
    -------
    entry : ndarray, shape (R,)
        Distance to the first crossing of the footprint's boundary; 0 when the
        origin is inside; inf when the ray misses.
    chord : ndarray, shape (R,)
        Distance between the first and last crossing (0 when the ray misses).
    """
    x0, y0, x1, y1 = rel
    s0 = ux * y0
    s0 -= uy * x0
    s1 = ux * y1
    s1 -= uy * x1
    crosses = (s0 > 0.0) != (s1 > 0.0)
    r0 = ux * x0
    r0 += uy * y0
    r = ux * x1
    r += uy * y1
    r -= r0
    r *= s0 / np.where(crosses, s0 - s1, 1.0)  # no 0/0: NaNs are slow as well as wrong
    r += r0
    ahead = crosses & (r > 0.0)
    inside = np.logical_xor.reduce(ahead, axis=0)
    first = np.where(ahead, r, np.inf).min(axis=0)
    last = np.where(ahead, r, -np.inf).max(axis=0)
    entry = np.where(inside, 0.0, first)
    chord = np.where(np.isfinite(first), last - entry, 0.0)
    return entry, chord


def _sectors(
    buildings: Buildings, target: NDArray[np.float64], altitude_m: float, reach_m: float, bins: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """Per-sector bounds ``near (bins,)``, ``far (bins,)`` and candidate table ``(bins, K)``."""
    tx, ty, tz = target
    width = 2.0 * np.pi / bins
    box = buildings.bbox
    gap_x = np.maximum(np.maximum(box[:, 0] - tx, tx - box[:, 2]), 0.0)
    gap_y = np.maximum(np.maximum(box[:, 1] - ty, ty - box[:, 3]), 0.0)
    gap = np.hypot(gap_x, gap_y)
    relevant = np.flatnonzero((buildings.heights > tz) & (gap <= reach_m + 1.0))
    if len(relevant) == 0:
        return np.full(bins, np.inf), np.full(bins, np.inf), np.full((bins, 0), -1, dtype=np.intp)
    n = len(relevant)
    factor = _factor(buildings.heights[relevant], tz, altitude_m)
    edges = buildings.edges[relevant]
    k0, count = _extents(box[relevant], gap[relevant], tx, ty, width, bins)
    # Sector-building pairs, grouped by building: pair i is sector pair_k[i] of building pair_b[i].
    offset = np.cumsum(count) - count
    pair_b = np.repeat(np.arange(n), count)
    pair_j = np.arange(len(pair_b)) - offset[pair_b]
    pair_k = np.mod(k0[pair_b] + pair_j, bins)
    # Boundary rays turned outwards by _ANGLE_MARGIN: sector j of a building lies
    # between its boundaries j and j + 1; ray 2i is boundary i turned clockwise,
    # ray 2i + 1 the same boundary turned counter-clockwise.
    ray_offset = offset + np.arange(n)
    ray_b = np.repeat(np.arange(n), count + 1)
    ray_k = np.mod(k0[ray_b] + np.arange(len(ray_b)) - ray_offset[ray_b], bins)
    boundary = -np.pi + np.arange(bins) * width
    cos_k, sin_k = np.cos(boundary)[ray_k], np.sin(boundary)[ray_k]
    cm, sm = math.cos(_ANGLE_MARGIN), math.sin(_ANGLE_MARGIN)
    ux = np.stack([cos_k * cm + sin_k * sm, cos_k * cm - sin_k * sm], axis=1).reshape(-1)
    uy = np.stack([sin_k * cm - cos_k * sm, sin_k * cm + cos_k * sm], axis=1).reshape(-1)
    entry, chord = _cast(ux, uy, _relative_edges(edges, tx, ty).take(np.repeat(ray_b, 2), axis=2))
    left = 2 * (ray_offset[pair_b] + pair_j)
    right = left + 3
    # Lower bound: distance to the footprint's part inside the widened sector.
    lower = np.minimum(entry[left], entry[right])
    point_b, point_d, point_theta = _closest_points(edges, target[:2])
    for shift in (-_ANGLE_MARGIN, _ANGLE_MARGIN):
        j = np.mod(np.floor((point_theta + shift) / width).astype(np.intp) - k0[point_b], bins)
        ok = j < count[point_b]
        np.minimum.at(lower, offset[point_b[ok]] + j[ok], point_d[ok])
    # A footprint (nearly) touching the target may decide any query within
    # rounding error: no query may skip the exact test because of it.
    touching = np.full(n, np.inf)
    np.minimum.at(touching, point_b, point_d)
    touching = touching <= _TOUCH_M
    lower = np.where(touching[pair_b], 0.0, lower) * factor[pair_b]
    # Upper bound: a convex footprint crossed by both widened boundary rays
    # contains the segment between their entry points, which every ray of the
    # sector crosses.
    covers = (buildings.convex[relevant][pair_b] & ~touching[pair_b]
              & (chord[left] > _MIN_CHORD_M) & (chord[right] > _MIN_CHORD_M))
    upper = np.where(covers, np.maximum(entry[left], entry[right]) * factor[pair_b], np.inf)
    near = np.full(bins, np.inf)
    far = np.full(bins, np.inf)
    np.minimum.at(near, pair_k, lower)
    np.minimum.at(far, pair_k, upper)
    near = near * (1.0 - _REL_MARGIN) - _ABS_MARGIN_M
    far = far * (1.0 + _REL_MARGIN) + _ABS_MARGIN_M
    # Candidates: buildings that may block a query between near and far.
    keep = np.isfinite(lower) & (lower <= far[pair_k])
    candidates = _table(pair_k[keep], relevant[pair_b[keep]], bins)
    for array in (near, far, candidates):
        array.flags.writeable = False
    return near, far, candidates


def _extents(
    box: NDArray[np.float64], gap: NDArray[np.float64], tx: float, ty: float, width: float, bins: int
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """First sector ``k0`` (unwrapped) and sector ``count`` of each bounding box seen from (tx, ty).

    Widened by _ANGLE_MARGIN; boxes within _TOUCH_M of the target get every sector.
    """
    cx, cy = box[:, [0, 2, 2, 0]] - tx, box[:, [1, 1, 3, 3]] - ty
    centre = np.arctan2(0.5 * (box[:, 1] + box[:, 3]) - ty, 0.5 * (box[:, 0] + box[:, 2]) - tx)
    spread = np.mod(np.arctan2(cy, cx) - centre[:, None] + np.pi, 2.0 * np.pi) - np.pi
    k0 = np.floor((centre + spread.min(axis=1) - _ANGLE_MARGIN + np.pi) / width).astype(np.intp)
    k1 = np.floor((centre + spread.max(axis=1) + _ANGLE_MARGIN + np.pi) / width).astype(np.intp)
    count = k1 - k0 + 1
    everywhere = (gap <= _TOUCH_M) | (count >= bins)
    return np.where(everywhere, 0, k0), np.where(everywhere, bins, count)


def _closest_points(
    edges: NDArray[np.float64], origin: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """Candidates for the point of a footprint nearest ``origin`` inside any wedge.

    Per edge, its point nearest the origin (perpendicular foot or an end) and its
    start vertex: a nearest point of (footprint x wedge) not on the wedge's rays
    is one of these. Returns the footprint index, distance and azimuth + pi of
    each, flattened.
    """
    start, end = edges[:, :, 0, :] - origin, edges[:, :, 1, :] - origin
    along = end - start
    length2 = np.sum(along * along, axis=-1)
    t = np.clip(-np.sum(start * along, axis=-1) / np.where(length2 > 0.0, length2, 1.0), 0.0, 1.0)
    points = np.concatenate([start + t[..., None] * along, start], axis=1)
    owner = np.broadcast_to(np.arange(len(edges))[:, None], points.shape[:2]).reshape(-1)
    points = points.reshape(-1, 2)
    return owner, np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0]) + np.pi


def _table(sector: NDArray[np.intp], building: NDArray[np.intp], bins: int) -> NDArray[np.intp]:
    """Padded table (bins, K) of the buildings of each sector, -1 for padding."""
    order = np.argsort(sector, kind="stable")
    sector, building = sector[order], building[order]
    per_sector = np.bincount(sector, minlength=bins)
    slot = np.arange(len(sector)) - (np.cumsum(per_sector) - per_sector)[sector]
    table = np.full((bins, int(per_sector.max(initial=0))), -1, dtype=np.intp)
    table[sector, slot] = building
    return table
