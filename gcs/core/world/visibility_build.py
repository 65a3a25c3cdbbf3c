"""Building a :class:`~gcs.core.world.visibility.VisibilityMap`: per-sector bounds and candidate buildings.

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

import numpy as np
from numpy.typing import NDArray

from gcs.core.world.buildings import Buildings

__all__ = ["blocking_factor", "cast_rays", "relative_edges", "sectors"]

_ANGLE_MARGIN = 1e-6
"""Radians by which building extents and vertex sectors are widened."""
_TOUCH_M = 1e-3
"""Buildings this close to the target are candidates in every sector and allow no shortcut."""
_REL_MARGIN = 1e-9
_ABS_MARGIN_M = 1e-6
"""Decided-without-the-exact-test queries clear their bound by this much, relative plus absolute."""
_MIN_CHORD_M = 1e-6
"""A boundary ray must cross a footprint by this much for the footprint to give an upper bound."""


def blocking_factor(heights: NDArray[np.float64], tz: float, altitude_m: float) -> NDArray[np.float64]:
    """max(1, (h - z_t) / (H - z_t)): how far past its entry point a building still hides the target."""
    with np.errstate(divide="ignore"):
        return np.where(heights > tz, np.maximum(1.0, (altitude_m - tz) / (heights - tz)), np.inf)


def relative_edges(edges: NDArray[np.float64], ox: float, oy: float) -> NDArray[np.float64]:
    """Edges (n, E, 2, 2) relative to (ox, oy) as one contiguous array (4, E, n): x0, y0, x1, y1."""
    rel = edges.transpose(2, 3, 1, 0) - np.array([ox, oy])[None, :, None, None]
    return np.ascontiguousarray(rel.reshape(4, edges.shape[1], edges.shape[0]))


def cast_rays(
    ux: NDArray[np.float64], uy: NDArray[np.float64], rel: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rays from the origin along unit vectors (ux, uy) (R,), each against one footprint.

    ``rel`` (4, E, R) holds each ray's footprint edges relative to the ray's
    origin (:func:`relative_edges`), edge-major so reductions run over the
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


def sectors(
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
    factor = blocking_factor(buildings.heights[relevant], tz, altitude_m)
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
    entry, chord = cast_rays(ux, uy, relative_edges(edges, tx, ty).take(np.repeat(ray_b, 2), axis=2))
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
