"""Line of sight between points among box buildings, and the visibility maps built on it.

:func:`line_of_sight` is the exact reference: for every pair of points it tells
whether any building's prism (footprint x [0, height]) hides one from the
other. :class:`VisibilityMap` (wang2012 section 2.5: the visibility region
X^{hV}(x) of a target at vehicle height h, used by the eq. 22 condition) answers
the same question for one target point and one altitude, much faster, with
identical answers, and :class:`VisibilityMaps` answers several such maps (the
predicted points of a horizon) in one call; they live in
:mod:`gcs.core.world.visibility` and are re-exported here.

Tangency: contact with a building's boundary only (a wall, a corner, the roof
plane) does not block; see :mod:`gcs.core.world._kernel` for the exact rule.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._kernel import box_overlap, canonical_order, combos_blocked
from gcs.core.world.buildings import Buildings
from gcs.core.world.visibility import DEFAULT_BINS, VisibilityMap, VisibilityMaps, visibility_map, visibility_maps

__all__ = ["line_of_sight", "VisibilityMap", "VisibilityMaps", "visibility_map", "visibility_maps", "DEFAULT_BINS"]

_CHUNK = 1 << 18
"""Largest (pairs x buildings) block handled at once, to bound memory."""


def line_of_sight(buildings: Buildings, a_xyz: ArrayLike, b_xyz: ArrayLike) -> NDArray[np.bool_]:
    """Whether each pair of points sees each other past the buildings.

    Parameters
    ----------
    buildings : Buildings
    a_xyz, b_xyz : array_like, shape (..., 3)
        ENU metres; broadcast against each other (e.g. one target against many
        vehicle positions).

    Returns
    -------
    ndarray of bool, shape broadcast(a.shape[:-1], b.shape[:-1])
        True when the open segment a-b enters no building's open prism
        (footprint interior x (0, height)); False when a coordinate is not finite. Grazing contact (a wall, a corner,
        the roof plane) does not block. Symmetric: ``los(a, b) == los(b, a)``
        exactly.

    Notes
    -----
    Exact per (pair, building): a bounding-box prefilter, then the clipping
    test of :mod:`gcs.core.world._kernel` for the pairs and buildings that pass,
    vectorised over both.
    """
    a = np.asarray(a_xyz, dtype=np.float64)
    b = np.asarray(b_xyz, dtype=np.float64)
    if a.shape[-1:] != (3,) or b.shape[-1:] != (3,):
        raise ValueError(f"points must have shape (..., 3), got {a.shape} and {b.shape}")
    a, b = np.broadcast_arrays(a, b)
    shape = a.shape[:-1]
    p, q = canonical_order(a.reshape(-1, 3), b.reshape(-1, 3))
    count = len(p)
    visible = np.isfinite(p).all(axis=1) & np.isfinite(q).all(axis=1)
    if len(buildings) == 0 or count == 0:
        return visible.reshape(shape)
    bbox, heights = buildings.bbox, buildings.heights
    step = max(1, _CHUNK // len(buildings))
    for first in range(0, count, step):
        pc, qc = p[first:first + step], q[first:first + step]
        near = box_overlap(pc[:, None, :], qc[:, None, :], bbox[None], heights[None])
        near &= visible[first:first + step, None]  # skip non-finite pairs
        pair, building = np.nonzero(near)
        if len(pair) == 0:
            continue
        blocked = combos_blocked(buildings, pc[pair], qc[pair], building)
        visible[first + pair[blocked]] = False
    return visible.reshape(shape)
