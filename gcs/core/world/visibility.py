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

How the map is built so that it stays exact is :mod:`gcs.core.world.visibility_build`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._kernel import canonical_order, combos_blocked
from gcs.core.world.visibility_build import blocking_factor, cast_rays, relative_edges, sectors
from gcs.core.world.buildings import Buildings

__all__ = ["DEFAULT_BINS", "VisibilityMap", "VisibilityMaps", "visibility_map", "visibility_maps"]

DEFAULT_BINS = 1024
"""Default number of angular sectors."""

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
            rel = relative_edges(self.buildings.edges, tx, ty).take(index, axis=2)
            entry, _ = cast_rays(np.cos(flat[ray]), np.sin(flat[ray]), rel)
            reach = entry * blocking_factor(self.buildings.heights[index], tz, self.altitude_m)
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
    result: NDArray[np.bool_] = in_range & near
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
    near, far, candidates = sectors(buildings, target, float(altitude_m), reach_m, bins)
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
