"""Polygon helpers shared by buildings and restricted airspace.

* :func:`as_ring` validates one polygon given as vertices (k, 2) in ENU metres.
* :func:`pad_edges` turns a list of rings into the padded edge array
  ``edges (P, E, 2, 2)`` (``edges[p, e, 0]`` is the start vertex, ``edges[p, e, 1]``
  the end vertex of edge ``e`` of polygon ``p``) used by every vectorised test.
  Padding edges are zero-length edges at the ring's first vertex, so that they
  never cross anything even when a caller forgets ``edge_valid``.
* :func:`even_odd` is the vectorised even-odd (crossing number) point-in-polygon
  rule with the half-open convention ``(y0 > y) != (y1 > y)``: points on the
  boundary may count either way, but each point gets one deterministic answer.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["as_ring", "signed_area", "pad_edges", "bboxes", "even_odd", "inside_any", "distances", "farthest_vertex"]

_CHUNK = 1 << 18
"""Largest (points x polygons) block handled at once, to bound memory."""


def as_ring(points: ArrayLike, what: str) -> NDArray[np.float64]:
    """Validate one polygon and return its vertices as a float64 array (k, 2).

    A repeated closing vertex (first == last, as in GeoJSON) is dropped.

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Vertices in ENU metres, in order (either orientation).
    what : str
        Name used in error messages, e.g. ``"polygon 3"``.

    Raises
    ------
    ValueError
        Not a (k, 2) array of finite numbers, fewer than 3 distinct vertices, or
        zero area.
    """
    try:
        ring = np.array(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: vertices must be numbers, shape (k, 2)") from None
    if ring.ndim != 2 or ring.shape[1] != 2:
        raise ValueError(f"{what}: vertices must have shape (k, 2), got {ring.shape}")
    if not np.all(np.isfinite(ring)):
        raise ValueError(f"{what}: vertices must be finite")
    if len(ring) >= 2 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    if len(ring) < 3:
        raise ValueError(f"{what}: needs at least 3 vertices, got {len(ring)}")
    if signed_area(ring) == 0.0:
        raise ValueError(f"{what}: zero area (collinear or repeated vertices)")
    return ring


def signed_area(ring: NDArray[np.float64]) -> float:
    """Shoelace area of a ring (k, 2), m^2: positive when counter-clockwise."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def pad_edges(rings: Sequence[NDArray[np.float64]]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Edges of every ring, padded to the longest ring.

    Returns
    -------
    edges : ndarray, shape (P, E, 2, 2)
        ``edges[p, e] = [[x0, y0], [x1, y1]]``; edge ``e`` runs from vertex ``e``
        to vertex ``e + 1`` (cyclically). ``E`` is the largest vertex count
        (0 when there are no rings).
    edge_valid : ndarray of bool, shape (P, E)
        False for padding (zero-length edges at the ring's first vertex).
    """
    count = len(rings)
    width = max((len(r) for r in rings), default=0)
    edges = np.zeros((count, width, 2, 2))
    valid = np.zeros((count, width), dtype=bool)
    for index, ring in enumerate(rings):
        k = len(ring)
        edges[index, :k, 0] = ring
        edges[index, :k, 1] = np.roll(ring, -1, axis=0)
        edges[index, k:] = ring[0]
        valid[index, :k] = True
    return edges, valid


def bboxes(edges: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bounding boxes (P, 4) = xmin, ymin, xmax, ymax of padded edge arrays (P, E, 2, 2)."""
    if edges.shape[0] == 0:
        return np.zeros((0, 4))
    starts = edges[:, :, 0, :]
    return np.concatenate([starts.min(axis=1), starts.max(axis=1)], axis=1)


def even_odd(x: NDArray[np.float64], y: NDArray[np.float64], edges: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Even-odd point-in-polygon test, vectorised.

    Parameters
    ----------
    x, y : ndarray, shape (M,)
        Query points, metres.
    edges : ndarray, shape (M, E, 2, 2)
        The polygon to test each point against (padded edges).

    Returns
    -------
    ndarray of bool, shape (M,)
        True where the horizontal ray from the point towards +x crosses an odd
        number of edges (half-open rule in y; boundary points either way).
    """
    x0, y0 = edges[:, :, 0, 0], edges[:, :, 0, 1]
    x1, y1 = edges[:, :, 1, 0], edges[:, :, 1, 1]
    yy = y[:, None]
    straddles = (y0 > yy) != (y1 > yy)
    denominator = np.where(straddles, y1 - y0, 1.0)
    x_cross = x0 + (yy - y0) * (x1 - x0) / denominator
    crossings = straddles & (x[:, None] < x_cross)
    inside: NDArray[np.bool_] = np.count_nonzero(crossings, axis=1) % 2 == 1
    return inside


def inside_any(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    bbox: NDArray[np.float64],
    edges: NDArray[np.float64],
    admit: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """Whether each point (M,) lies inside any of the polygons (even-odd rule).

    Parameters
    ----------
    x, y : ndarray, shape (M,)
    bbox : ndarray, shape (P, 4)
        Polygon bounding boxes (a prefilter).
    edges : ndarray, shape (P, E, 2, 2)
    admit : ndarray of bool, shape (M, P), optional
        Further (point, polygon) combinations to consider, e.g. an altitude band.
    """
    inside = np.zeros(len(x), dtype=bool)
    if len(bbox) == 0:
        return inside
    step = max(1, _CHUNK // len(bbox))
    for first in range(0, len(x), step):
        xc, yc = x[first:first + step, None], y[first:first + step, None]
        near = (xc >= bbox[:, 0]) & (xc <= bbox[:, 2]) & (yc >= bbox[:, 1]) & (yc <= bbox[:, 3])
        if admit is not None:
            near &= admit[first:first + step]
        point, polygon = np.nonzero(near)
        hit = even_odd(xc[point, 0], yc[point, 0], edges[polygon])
        inside[first + point[hit]] = True
    return inside


def distances(x: NDArray[np.float64], y: NDArray[np.float64], edges: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (M, P) from each point (M,) to each polygon (P, E, 2, 2): 0 inside (even-odd), else to the outline.

    Padding edges are zero-length edges at a vertex, whose distance is that
    vertex's, so they change nothing.
    """
    px, py = x[:, None, None], y[:, None, None]
    x0, y0 = edges[None, :, :, 0, 0], edges[None, :, :, 0, 1]
    ex, ey = edges[None, :, :, 1, 0] - x0, edges[None, :, :, 1, 1] - y0
    length2 = ex * ex + ey * ey
    t = np.clip(((px - x0) * ex + (py - y0) * ey) / np.where(length2 > 0.0, length2, 1.0), 0.0, 1.0)
    outline = np.hypot(px - x0 - t * ex, py - y0 - t * ey).min(axis=-1)
    straddles = (y0 > py) != (edges[None, :, :, 1, 1] > py)
    x_cross = x0 + (py - y0) * ex / np.where(straddles, ey, 1.0)
    inside = np.count_nonzero(straddles & (px < x_cross), axis=-1) % 2 == 1
    return np.where(inside, 0.0, outline)


def farthest_vertex(x: NDArray[np.float64], y: NDArray[np.float64], edges: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (M, P) from each point (M,) to the farthest vertex of each polygon (P, E, 2, 2)."""
    dx = edges[None, :, :, 0, 0] - x[:, None, None]
    dy = edges[None, :, :, 0, 1] - y[:, None, None]
    farthest: NDArray[np.float64] = np.hypot(dx, dy).max(axis=-1)
    return farthest
