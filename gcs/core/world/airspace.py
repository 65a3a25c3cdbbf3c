"""Restricted airspace R_o of wang2012 eq. (5): a union of polygon prisms with altitude bands.

Each zone ``s`` is a polygon in ENU metres (any orientation, simple) with a
floor and a ceiling; a point is restricted when it lies inside the polygon and
``floor_m <= z <= ceiling_m`` for any zone. The RHC safety cost (eq. 25-26)
charges W_res for every planned position inside.

The core takes plain ``(polygon, floor_m, ceiling_m)`` tuples; converting the
scenario's ``[[restricted]]`` tables is done by ``gcs.config.world``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world._polygons import as_ring, bboxes, distances, farthest_vertex, inside_any, pad_edges

__all__ = ["RestrictedAirspace"]


@dataclass(frozen=True, eq=False)
class RestrictedAirspace:
    """No-fly zones as padded arrays (wang2012 eq. 5).

    Build with :meth:`from_zones` or :meth:`empty`.

    Attributes
    ----------
    polygons : tuple of ndarray, each shape (k_s, 2)
        Zone outlines, ENU metres.
    floors_m, ceilings_m : ndarray, shape (S,)
        Altitude band of each zone, metres (closed: floor <= z <= ceiling).
    edges : ndarray, shape (S, E, 2, 2)
        Padded polygon edges (see :mod:`gcs.core.world._polygons`).
    edge_valid : ndarray of bool, shape (S, E)
    bbox : ndarray, shape (S, 4)
        ``xmin, ymin, xmax, ymax``.
    names : tuple of str
        Zone names, for messages and plots.
    """

    polygons: tuple[NDArray[np.float64], ...]
    floors_m: NDArray[np.float64]
    ceilings_m: NDArray[np.float64]
    edges: NDArray[np.float64]
    edge_valid: NDArray[np.bool_]
    bbox: NDArray[np.float64]
    names: tuple[str, ...]

    @classmethod
    def from_zones(
        cls, zones: Sequence[tuple[ArrayLike, float, float]], names: Sequence[str] | None = None
    ) -> RestrictedAirspace:
        """Zones from ``(polygon (k, 2), floor_m, ceiling_m)`` tuples.

        Raises
        ------
        ValueError
            Naming the zone: bad polygon, non-finite band, floor not below ceiling.
        """
        labels = tuple(names) if names is not None else tuple(f"zone {i}" for i in range(len(zones)))
        if len(labels) != len(zones):
            raise ValueError(f"got {len(zones)} zones but {len(labels)} names")
        rings, floors, ceilings = [], [], []
        for label, (polygon, floor_m, ceiling_m) in zip(labels, zones, strict=True):
            rings.append(as_ring(polygon, label))
            floor_m, ceiling_m = float(floor_m), float(ceiling_m)
            if math.isnan(floor_m) or math.isnan(ceiling_m) or not floor_m < ceiling_m:
                raise ValueError(f"{label}: floor_m ({floor_m}) must be below ceiling_m ({ceiling_m})")
            floors.append(floor_m)
            ceilings.append(ceiling_m)
        edges, valid = pad_edges(rings)
        floor_array, ceiling_array = np.array(floors, dtype=np.float64), np.array(ceilings, dtype=np.float64)
        boxes = bboxes(edges)
        for array in (floor_array, ceiling_array, edges, valid, boxes, *rings):
            array.flags.writeable = False
        return cls(tuple(rings), floor_array, ceiling_array, edges, valid, boxes, labels)

    @classmethod
    def empty(cls) -> RestrictedAirspace:
        """No restricted airspace."""
        return cls.from_zones([])

    def __len__(self) -> int:
        return len(self.polygons)

    def inside(self, xyz: ArrayLike) -> NDArray[np.bool_]:
        """Whether each point is in restricted airspace (any zone).

        Parameters
        ----------
        xyz : array_like, shape (..., 3)
            ENU metres.

        Returns
        -------
        ndarray of bool, shape (...)
            Inside a zone's polygon (even-odd rule; points exactly on an outline
            may count either way) and within its closed altitude band.
        """
        p = np.asarray(xyz, dtype=np.float64)
        if p.shape[-1:] != (3,):
            raise ValueError(f"points must have shape (..., 3), got {p.shape}")
        flat = p.reshape(-1, 3)
        z = flat[:, 2, None]
        band = (z >= self.floors_m) & (z <= self.ceilings_m)
        result = inside_any(flat[:, 0], flat[:, 1], self.bbox, self.edges, admit=band)
        return result.reshape(p.shape[:-1])

    def active(self, altitude_m: float) -> NDArray[np.bool_]:
        """Which zones (S,) restrict the altitude ``altitude_m`` (closed band)."""
        return (self.floors_m <= altitude_m) & (altitude_m <= self.ceilings_m)

    def distances_xy(self, xy: ArrayLike, altitude_m: float, within_m: float = math.inf) -> NDArray[np.float64]:
        """Horizontal distance (..., S') from points (..., 2) to each zone restricting ``altitude_m``:
        0 inside, else to its outline. ``S'`` counts the zones :meth:`active` at that altitude.

        Only distances up to ``within_m`` are exact: a point whose gap to a zone's
        bounding box is larger gets that gap instead (a lower bound, above
        ``within_m``), which spares the outline test for everything far away.
        """
        p = np.asarray(xy, dtype=np.float64)
        flat = p.reshape(-1, 2)
        active = self.active(altitude_m)
        box, edges = self.bbox[active], self.edges[active]
        x, y = flat[:, 0:1], flat[:, 1:2]
        gap = np.hypot(np.maximum(np.maximum(box[:, 0] - x, x - box[:, 2]), 0.0),
                       np.maximum(np.maximum(box[:, 1] - y, y - box[:, 3]), 0.0))
        rows = np.flatnonzero((gap <= within_m).any(axis=1))
        if len(rows):
            gap[rows] = distances(flat[rows, 0], flat[rows, 1], edges)
        return gap.reshape(p.shape[:-1] + (len(edges),))

    def farthest_xy(self, xy: ArrayLike, altitude_m: float) -> NDArray[np.float64]:
        """Distance (..., S') from points (..., 2) to the farthest vertex of each zone restricting ``altitude_m``."""
        p = np.asarray(xy, dtype=np.float64)
        flat = p.reshape(-1, 2)
        edges = self.edges[self.active(altitude_m)]
        return farthest_vertex(flat[:, 0], flat[:, 1], edges).reshape(p.shape[:-1] + (len(edges),))
