"""Where the vehicles' sensors look: which ground points a scan covered, and the clutter's volume.

A vehicle at ``v`` (ENU, m) covers a ground point ``p`` (the target's height ``h`` above it)
when the slant range is within the sensor's

.. math:: \\sqrt{\\lVert p - v_{xy} \\rVert^2 + (v_z - h)^2} \\le r_{max},

and the segment from ``v`` to ``(p, h + 1 m)`` clears every building
(:meth:`gcs.core.world.World.line_of_sight`). The tracker counts a missed scan only
for a track some vehicle covered (:mod:`gcs.core.multitarget.tracks`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from gcs.core.world import World

__all__ = ["sight_matrix", "in_field", "coverage", "clutter_volume"]


def sight_matrix(world: World, points_xy: NDArray[np.float64], vehicles: NDArray[np.float64],
                 target_height_m: float) -> NDArray[np.bool_]:
    """(V, N): UAV v (V, 3) has a line of sight past the buildings to ground point j (N, 2), 1 m above the
    target height."""
    ground = np.column_stack([points_xy, np.full(len(points_xy), target_height_m + 1.0)])
    return world.line_of_sight(np.broadcast_to(vehicles[:, None, :], (len(vehicles), len(points_xy), 3)),
                               np.broadcast_to(ground[None], (len(vehicles), len(points_xy), 3)))


def in_field(world: World, points_xy: NDArray[np.float64], vehicles: NDArray[np.float64], target_height_m: float,
             max_range_m: float) -> NDArray[np.bool_]:
    """(V, N): UAV v (V, 3) has ground point j (N, 2) within slant range and in sight past the buildings."""
    sight = sight_matrix(world, points_xy, vehicles, target_height_m)
    slant = np.sqrt(((points_xy[None] - vehicles[:, None, :2]) ** 2).sum(-1)
                    + (vehicles[:, None, 2] - target_height_m) ** 2)
    covered: NDArray[np.bool_] = sight & (slant <= max_range_m)
    return covered


def coverage(world: World, vehicles: NDArray[np.float64], target_height_m: float,
             max_range_m: float) -> Callable[[NDArray[np.float64]], NDArray[np.bool_]]:
    """The tracker's ``in_view`` for one scan: which ground points (T, 2) some UAV (V, 3) covers."""
    def in_view(points_xy: NDArray[np.float64]) -> NDArray[np.bool_]:
        seen: NDArray[np.bool_] = np.any(in_field(world, points_xy, vehicles, target_height_m, max_range_m), axis=0)
        return seen

    return in_view


def clutter_volume(max_range_m: float) -> float:
    """Measurement-space volume (range x azimuth x downward elevation, m rad^2) the clutter is spread over."""
    return max_range_m * 2.0 * math.pi * (math.pi / 2.0)
