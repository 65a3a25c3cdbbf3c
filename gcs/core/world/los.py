"""Line of sight between points among box buildings, and the visibility maps built on it.

:func:`line_of_sight` is the exact reference: for every pair of points it tells
whether any building's prism (footprint x [0, height]) hides one from the
other. :class:`VisibilityMap` (wang2012 section 2.5: the visibility region
X^{hV}(x) of a target at vehicle height h, used by the eq. 22 condition) answers
the same question for one target point and one altitude, much faster, with
identical answers, and :class:`VisibilityMaps` answers several such maps (the
predicted points of a horizon) in one call; they live in
:mod:`gcs.core.world.visibility` and are re-exported here. :class:`SightLines`
answers as the maps do, without building them, for callers with few queries.

Tangency: contact with a building's boundary only (a wall, a corner, the roof
plane) does not block; see :mod:`gcs.core.world._kernel` for the exact rule.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._kernel import box_overlap, canonical_order, combos_blocked
from gcs.core.world.buildings import Buildings
from gcs.core.world.visibility import DEFAULT_BINS, VisibilityMap, VisibilityMaps, visibility_map, visibility_maps

__all__ = ["line_of_sight", "SightLines", "VisibilityMap", "VisibilityMaps", "visibility_map", "visibility_maps",
           "DEFAULT_BINS"]

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
    visible: NDArray[np.bool_] = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(q), axis=1)
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


class SightLines:
    """The visibility of predicted target points decided by :func:`line_of_sight`, one query at a time.

    Answers :meth:`VisibilityMaps.visible` (the wang2012 eq. 22 condition: within
    ``max_range_m``, 3-D, and an open sight line from the target point at
    ``target_height_m`` to the vehicle at ``altitude_m``) identically, without
    building the maps. Building a map costs milliseconds and pays off over many
    queries (the GA asks population x generations x vehicles x horizon of them per
    plan); a planner that scores a single plan (orbit, pursuit, the heading
    planners) asks vehicles x horizon, which the sight lines answer at once.

    Parameters
    ----------
    buildings : Buildings
    target_xys : array_like, shape (n, 2)
        The predicted target points, ENU metres.
    altitude_m, max_range_m, target_height_m : float
        As for :func:`visibility_maps`.
    """

    def __init__(self, buildings: Buildings, target_xys: ArrayLike, altitude_m: float, max_range_m: float,
                 target_height_m: float = 0.0) -> None:
        points = np.asarray(target_xys, dtype=np.float64).reshape(-1, 2)
        self.buildings = buildings
        self.targets = np.column_stack([points, np.full(len(points), float(target_height_m))])
        self.altitude_m = float(altitude_m)
        self.max_range_m = float(max_range_m)

    def __len__(self) -> int:
        return len(self.targets)

    def visible(self, vehicle_xy: ArrayLike) -> NDArray[np.bool_]:
        """Point ``i`` answers the positions ``vehicle_xy[..., i, :]`` (shape (..., n, 2)) -> (..., n)."""
        xy = np.asarray(vehicle_xy, dtype=np.float64)
        if xy.ndim < 2 or xy.shape[-2:] != (len(self.targets), 2):
            raise ValueError(f"vehicle_xy must have shape (..., {len(self.targets)}, 2), got {xy.shape}")
        dx = xy[..., 0] - self.targets[:, 0]
        dy = xy[..., 1] - self.targets[:, 1]
        dz = self.altitude_m - self.targets[:, 2]
        result: NDArray[np.bool_] = dx * dx + dy * dy + dz * dz <= self.max_range_m * self.max_range_m
        asked = np.nonzero(result)
        if len(asked[0]):
            vehicles = np.column_stack([xy[asked], np.full(len(asked[0]), self.altitude_m)])
            result[asked] = line_of_sight(self.buildings, self.targets[asked[-1]], vehicles)
        return result
