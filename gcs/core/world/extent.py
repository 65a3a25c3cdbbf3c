"""The extent of a world: the ground rectangle that the maps draw and a free-driving target keeps to.

A generated city's extent is its ``size_m`` rectangle from the ENU origin. A
city read from files (real footprints, real roads) sits wherever its
coordinates put it, often about the origin rather than north-east of it, so its
extent is taken from its content: the bounding box of its building footprints,
its road nodes and any extra points (the scenario's start points), widened by
:data:`FRAME_MARGIN_M` on every side,

.. math::
    [x_{min} - m, x_{max} + m] \\times [y_{min} - m, y_{max} + m].
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from gcs.core.roads.graph import RoadGraph
    from gcs.core.world.buildings import Buildings

__all__ = ["Bounds", "FRAME_MARGIN_M", "rectangle_bounds", "content_bounds"]

Bounds = tuple[float, float, float, float]
"""``x_min, y_min, x_max, y_max``, ENU metres."""

FRAME_MARGIN_M = 100.0
"""Open ground kept around a city's content, metres: about a city block, so that the roads at the edge
and a car on them have ground around them, and a UAV circling the edge mostly stays inside."""


def rectangle_bounds(size_m: Sequence[float]) -> Bounds:
    """The ``size_m = (width, depth)`` rectangle whose south-west corner is the origin."""
    return 0.0, 0.0, float(size_m[0]), float(size_m[1])


def content_bounds(buildings: Buildings, roads: RoadGraph | None = None, points: ArrayLike = (),
                   margin_m: float = FRAME_MARGIN_M) -> Bounds | None:
    """The bounding box of the footprints, the road nodes and ``points`` (n, 2), widened by ``margin_m``.

    None when there is nothing to frame (no building, no road, no point).
    """
    corners = [np.asarray(points, dtype=np.float64).reshape(-1, 2)]
    if len(buildings):
        corners += [buildings.bbox[:, :2], buildings.bbox[:, 2:]]
    if roads is not None:
        corners.append(roads.nodes)
    every = np.concatenate(corners)
    if len(every) == 0:
        return None
    low, high = every.min(axis=0) - margin_m, every.max(axis=0) + margin_m
    return float(low[0]), float(low[1]), float(high[0]), float(high[1])
