"""The exact segment-versus-prism test that every line-of-sight answer comes from.

Both :func:`gcs.core.world.los.line_of_sight` and
:meth:`gcs.core.world.visibility.VisibilityMap.visible` decide each (segment,
building) combination with :func:`combos_blocked`, an elementwise function of
the combination's numbers. That is what makes the visibility map's answers
identical to ``line_of_sight``'s, not merely close.

Definition (tangency)
---------------------
A segment is **blocked** by a building when the segment's open interior meets
the prism's open interior, footprint interior x (0, height). Contact with the
boundary only -- touching a wall or a corner, running along a wall, along the
roof plane or along the ground -- does not block. This holds exactly for
segments in general position and for the degenerate cases (a segment through
a footprint vertex or collinear with a wall); contacts within rounding error
of a boundary are decided one deterministic way. The two endpoints are put in
a canonical (lexicographic) order first, so the answer is symmetric bit for bit.

A segment whose horizontal length is below 1e-9 m counts as vertical: it is
blocked when its (x, y) is inside the footprint (even-odd rule) and it spans
part of (0, height); a zero-length segment is never blocked.

Method: along the segment ``P(t) = p + t (q - p)``, ``t`` in (0, 1), the roof
and ground planes bound ``t`` to an open window (lo, hi); the footprint's
interior along the segment's supporting line is the union of the intervals
between consecutive sorted edge crossings (even-odd rule with the half-open
vertex convention ``s > 0``). Where a vertex lies exactly on the line, the
intervals for the opposite convention ``s >= 0`` are intersected in, which
removes runs along a wall and point contacts. Blocked iff some interval
overlaps (lo, hi) with positive length.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.world._polygons import even_odd
from gcs.core.world.buildings import Buildings

__all__ = ["canonical_order", "box_overlap", "combos_blocked"]


def canonical_order(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Swap endpoints so that ``p <= q`` lexicographically in (x, y, z); shapes (N, 3)."""
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (
        (a[:, 1] > b[:, 1]) | ((a[:, 1] == b[:, 1]) & (a[:, 2] > b[:, 2]))))
    s = swap[:, None]
    return np.where(s, b, a), np.where(s, a, b)


def box_overlap(
    p: NDArray[np.float64], q: NDArray[np.float64], bbox: NDArray[np.float64], height: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Cheap prefilter: the segment's bounding box meets the building's box.

    Broadcasts: ``p, q`` (..., 3) against ``bbox`` (..., 4) and ``height`` (...).
    False only where :func:`_prism_blocked` is certainly False (the segment stays
    on or beyond one face of the box), so it never changes an answer.
    """
    lo_x, hi_x = np.minimum(p[..., 0], q[..., 0]), np.maximum(p[..., 0], q[..., 0])
    lo_y, hi_y = np.minimum(p[..., 1], q[..., 1]), np.maximum(p[..., 1], q[..., 1])
    lo_z, hi_z = np.minimum(p[..., 2], q[..., 2]), np.maximum(p[..., 2], q[..., 2])
    return ((lo_x <= bbox[..., 2]) & (hi_x >= bbox[..., 0]) & (lo_y <= bbox[..., 3]) & (hi_y >= bbox[..., 1])
            & (lo_z < height) & (hi_z > 0.0))


def combos_blocked(
    buildings: Buildings, p: NDArray[np.float64], q: NDArray[np.float64], index: NDArray[np.intp]
) -> NDArray[np.bool_]:
    """Whether segment ``m`` is blocked by building ``index[m]``, for every m.

    Parameters
    ----------
    buildings : Buildings
    p, q : ndarray, shape (M, 3)
        Segment endpoints in canonical order (:func:`canonical_order`), ENU metres.
    index : ndarray of int, shape (M,)
        Building of each combination.

    Returns
    -------
    ndarray of bool, shape (M,)
    """
    bbox, height = buildings.bbox[index], buildings.heights[index]
    near = box_overlap(p, q, bbox, height)
    near[near] = _slab_overlap(p[near], q[near], bbox[near], height[near])
    blocked = np.zeros(len(index), dtype=bool)
    if near.any():
        blocked[near] = _prism_blocked(buildings, p[near], q[near], index[near])
    return blocked


_VERTICAL_M2 = 1e-18
"""Segments whose horizontal length is at most 1e-9 m (squared here) are treated as vertical."""

_SLAB_SLACK = 1e-9
"""Segment-parameter slack of the slab test, far above its rounding error."""


def _slab_overlap(
    p: NDArray[np.float64], q: NDArray[np.float64], bbox: NDArray[np.float64], height: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Second prefilter for combinations that passed :func:`box_overlap`: the
    segment itself (not only its bounding box) meets the building's closed box
    (Liang-Barsky slab clipping, with slack so that it never rejects a segment
    the exact test could call blocked). Shapes (M, 3), (M, 3), (M, 4), (M,).
    """
    enter = np.zeros(len(p))
    leave = np.ones(len(p))
    for axis, lo, hi in ((0, bbox[:, 0], bbox[:, 2]), (1, bbox[:, 1], bbox[:, 3]), (2, 0.0, height)):
        d = q[:, axis] - p[:, axis]
        moving = d != 0.0  # a still axis is already inside the box by box_overlap
        safe = np.where(moving, d, 1.0)
        with np.errstate(over="ignore"):  # tiny d: t = +-inf is right
            t_lo, t_hi = (lo - p[:, axis]) / safe, (hi - p[:, axis]) / safe
        enter = np.where(moving, np.maximum(enter, np.minimum(t_lo, t_hi)), enter)
        leave = np.where(moving, np.minimum(leave, np.maximum(t_lo, t_hi)), leave)
    return enter <= leave + _SLAB_SLACK


def _prism_blocked(
    buildings: Buildings, p: NDArray[np.float64], q: NDArray[np.float64], index: NDArray[np.intp]
) -> NDArray[np.bool_]:
    """Exact test (see the module docstring) for combinations that passed the prefilter."""
    edges = buildings.edges[index]
    height = buildings.heights[index]
    ax, ay, az = p[:, 0], p[:, 1], p[:, 2]
    dx, dy, dz = q[:, 0] - ax, q[:, 1] - ay, q[:, 2] - az
    lo, hi = _height_window(az, dz, height)
    l2 = dx * dx + dy * dy
    vertical = l2 <= _VERTICAL_M2
    blocked = np.zeros(len(index), dtype=bool)
    if vertical.any():
        # Vertical segment: blocked iff it has length, its (x, y) is inside the
        # footprint and its z range overlaps (0, height) with positive length.
        v = vertical
        blocked[v] = even_odd(ax[v], ay[v], edges[v]) & (lo[v] < hi[v]) & (dz[v] != 0.0)
    rows = ~vertical
    if not rows.any():
        return blocked
    e = edges[rows]
    x0, y0 = e[:, :, 0, 0] - ax[rows, None], e[:, :, 0, 1] - ay[rows, None]
    x1, y1 = e[:, :, 1, 0] - ax[rows, None], e[:, :, 1, 1] - ay[rows, None]
    ddx, ddy, length2 = dx[rows, None], dy[rows, None], l2[rows, None]
    s0 = ddx * y0 - ddy * x0  # side of each edge's start (> 0: left of p -> q)
    s1 = ddx * y1 - ddy * x1
    u0 = (ddx * x0 + ddy * y0) / length2  # segment parameter of the projections
    u1 = (ddx * x1 + ddy * y1) / length2
    lo_r, hi_r = lo[rows, None], hi[rows, None]
    start_a, end_a = _intervals((s0 > 0.0) != (s1 > 0.0), s0, s1, u0, u1)
    hit = np.any(np.maximum(start_a, lo_r) < np.minimum(end_a, hi_r), axis=1)
    degenerate = np.any((s0 == 0.0) | (s1 == 0.0), axis=1)
    if degenerate.any():
        g = degenerate
        start_b, end_b = _intervals((s0[g] >= 0.0) != (s1[g] >= 0.0), s0[g], s1[g], u0[g], u1[g])
        start = np.maximum(np.maximum(start_a[g][:, :, None], start_b[:, None, :]), lo_r[g][:, :, None])
        end = np.minimum(np.minimum(end_a[g][:, :, None], end_b[:, None, :]), hi_r[g][:, :, None])
        hit[g] = np.any(start < end, axis=(1, 2))
    blocked[rows] = hit
    return blocked


def _height_window(
    az: NDArray[np.float64], dz: NDArray[np.float64], height: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Open window (lo, hi) of t in (0, 1) where 0 < z(t) < height; empty when lo >= hi."""
    flat = dz == 0.0
    safe = np.where(flat, 1.0, dz)
    with np.errstate(over="ignore"):  # tiny dz: t = +-inf is right
        t_ground = (0.0 - az) / safe
        t_roof = (height - az) / safe
    lo = np.maximum(0.0, np.minimum(t_ground, t_roof))
    hi = np.minimum(1.0, np.maximum(t_ground, t_roof))
    inside = (az > 0.0) & (az < height)
    lo = np.where(flat, np.where(inside, 0.0, np.inf), lo)
    hi = np.where(flat, np.where(inside, 1.0, -np.inf), hi)
    return lo, hi


def _intervals(
    crosses: NDArray[np.bool_],
    s0: NDArray[np.float64],
    s1: NDArray[np.float64],
    u0: NDArray[np.float64],
    u1: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Inside intervals of the footprint along the line, from the edges that cross it.

    Returns starts and ends, each (M, ceil(E / 2)); unused slots are (inf, inf).
    """
    denominator = np.where(crosses, s0 - s1, 1.0)
    t = np.where(crosses, u0 + (u1 - u0) * (s0 / denominator), np.inf)
    t.sort(axis=1)
    if t.shape[1] % 2:
        t = np.concatenate([t, np.full((len(t), 1), np.inf)], axis=1)
    return t[:, 0::2], t[:, 1::2]
