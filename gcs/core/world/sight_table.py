"""Where a ground point can be seen from: roof heights on a grid and, per ground point, its sky horizon.

The planner asks, for every candidate flight path, every horizon step and every
sample of the predicted target distribution, whether the vehicle would see the
target. That is tens of thousands of sight lines per decision, so it asks a
table instead of the exact test (:func:`gcs.core.world.los.line_of_sight`, which
the simulated sensor uses).

**Height field.** :class:`HeightField` holds the tallest roof over each cell of
a square grid (a cell takes the height of the building whose footprint holds
its centre).

**Horizon of a ground point.** Seen from a target point ``t`` at height ``z_t``,
a roof of height ``H > z_t`` at horizontal distance ``s`` along azimuth
``theta`` hides every vehicle at altitude ``h`` farther than
``s (h - z_t) / (H - z_t)`` along that azimuth (the sight line rises linearly
from the target to the vehicle; this is the visibility region of wang2012
section 2.5 with ``h > H``, see :mod:`gcs.core.world.visibility`). So

.. math::
    g(\\theta) = \\min_{s} \\frac{s}{H(t + s u_\\theta) - z_t}, \\qquad
    \\text{visible} \\iff D \\le (h - z_t)\\, g(\\theta) \\ \\text{and}\\ D^2 + (h - z_t)^2 \\le r_{max}^2,

with ``D`` the vehicle's horizontal distance. One table ``g`` (``bins``
azimuths) serves every vehicle altitude: each UAV is asked at its own height.
A roof at or above the vehicle counts as reaching it (``H - z_t`` is capped at
``h_ref - z_t`` with ``h_ref`` the lowest altitude the table is built for), so a
vehicle below a roof does not see past it.

**Where it is approximate.** ``s`` is sampled every ``cell_m`` out to 100 m and
every ``2 cell_m`` to ``reach_m`` (beyond, the sky is taken as open), the
azimuth is taken at the centre of its bin, and a point's table is that of the
nearest lattice node (``lattice_m`` apart). The nodes cover the height field and
``reach_m`` of open ground around it; a point farther out has no roof within
reach and sees open sky. The planner's target positions are
samples of a distribution tens of metres wide, so metre-scale errors do not
change which plan wins; ``tests/unit/test_sight_table.py`` measures the
agreement with the exact test.

**Memo.** A node's table is a pure function of the node, so :class:`SightTable`
keeps the tables it has computed (up to ``max_nodes``, then starts afresh):
answers never depend on what was asked before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.world.buildings import Buildings

__all__ = ["HeightField", "SightTable"]

_NEAR_M = 100.0
"""Out to this distance the horizon is sampled every cell, beyond it every two cells."""
_CHUNK_NODES = 64
"""New nodes computed per vectorised batch (bounds memory: nodes x bins x samples)."""


@dataclass(frozen=True, eq=False)
class HeightField:
    """Roof heights on a square grid: ``heights[i, j]`` covers ``x in [x0 + i c, x0 + (i + 1) c)``,
    ``y in [y0 + j c, y0 + (j + 1) c)``; 0 is open ground.

    Build with :meth:`from_buildings`. The grid's origin is a multiple of ``cell_m``.
    """

    heights: NDArray[np.float32]
    origin_xy: tuple[float, float]
    cell_m: float

    @classmethod
    def from_buildings(cls, buildings: Buildings, cell_m: float = 2.0, margin_m: float = 0.0) -> HeightField:
        """Rasterise footprints: each cell takes the tallest building containing its centre.

        The grid covers the buildings' bounding box plus ``margin_m`` of open
        ground on every side; outside it the ground is open too.
        """
        if not (math.isfinite(cell_m) and cell_m > 0.0):
            raise ValueError(f"cell_m must be finite and > 0, got {cell_m!r}")
        if len(buildings) == 0:
            return cls(np.zeros((1, 1), dtype=np.float32), (0.0, 0.0), float(cell_m))
        box = buildings.bbox
        x0 = math.floor((float(box[:, 0].min()) - margin_m) / cell_m) * cell_m
        y0 = math.floor((float(box[:, 1].min()) - margin_m) / cell_m) * cell_m
        nx = int(math.ceil((float(box[:, 2].max()) + margin_m - x0) / cell_m)) + 1
        ny = int(math.ceil((float(box[:, 3].max()) + margin_m - y0) / cell_m)) + 1
        heights = np.zeros((nx, ny), dtype=np.float32)
        for b in np.argsort(buildings.heights, kind="stable"):  # taller buildings written last win
            i0 = max(int(math.floor((box[b, 0] - x0) / cell_m)), 0)
            j0 = max(int(math.floor((box[b, 1] - y0) / cell_m)), 0)
            i1 = min(int(math.ceil((box[b, 2] - x0) / cell_m)) + 1, nx)
            j1 = min(int(math.ceil((box[b, 3] - y0) / cell_m)) + 1, ny)
            cx = x0 + (np.arange(i0, i1) + 0.5) * cell_m
            cy = y0 + (np.arange(j0, j1) + 0.5) * cell_m
            gx, gy = np.meshgrid(cx, cy, indexing="ij")
            inside = _inside_one(np.stack([gx.ravel(), gy.ravel()], axis=1),
                                 buildings.edges[b][buildings.edge_valid[b]])
            block = heights[i0:i1, j0:j1]
            block[inside.reshape(block.shape)] = buildings.heights[b]
        heights.flags.writeable = False
        return cls(heights, (x0, y0), float(cell_m))

    def cells(self, xy: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Cell indices (i, j) of points (..., 2); they may fall off the grid."""
        p = np.asarray(xy, dtype=np.float64)
        return (np.floor((p[..., 0] - self.origin_xy[0]) / self.cell_m).astype(np.intp),
                np.floor((p[..., 1] - self.origin_xy[1]) / self.cell_m).astype(np.intp))

    def at(self, xy: ArrayLike) -> NDArray[np.float32]:
        """Roof height at points (..., 2), 0 off the grid."""
        i, j = self.cells(xy)
        nx, ny = self.heights.shape
        on = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        return np.where(on, self.heights[np.clip(i, 0, nx - 1), np.clip(j, 0, ny - 1)], np.float32(0.0))


def _inside_one(points: NDArray[np.float64], edges: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Even-odd test of points (N, 2) against one polygon's edges (E, 2, 2)."""
    x, y = points[:, 0:1], points[:, 1:2]
    x0, y0, x1, y1 = edges[:, 0, 0], edges[:, 0, 1], edges[:, 1, 0], edges[:, 1, 1]
    straddles = (y0 > y) != (y1 > y)
    x_cross = x0 + (y - y0) * (x1 - x0) / np.where(straddles, y1 - y0, 1.0)
    inside: NDArray[np.bool_] = np.count_nonzero(straddles & (x < x_cross), axis=1) % 2 == 1
    return inside


class SightTable:
    """Horizon tables of ground points on a lattice, memoised (see the module docstring).

    The memo is filled as points are asked for; one thread at a time may ask (a table per thread otherwise).

    A table holds, per azimuth bin, ``1 / g(theta) = max_s (H - z_t) / s``
    (0: open sky): a vehicle at altitude ``h`` and horizontal distance ``D``
    along that azimuth sees the node iff ``D / g <= h - z_t`` (and is in range).

    Parameters
    ----------
    field : HeightField
    reference_altitude_m : float
        The lowest vehicle altitude asked about (roofs above it count as reaching it).
    target_height_m : float
        Height of the observed point on the target, ``z_t``.
    bins : int
        Azimuth bins; bin ``k`` covers azimuths ``[-pi + k w, -pi + (k + 1) w)``,
        ``w = 2 pi / bins``, and is sampled at its centre.
    lattice_cells : int
        Spacing of the nodes whose tables are computed, in cells of the field.
    reach_m : float
        How far along each azimuth roofs are looked for.
    max_nodes : int
        Tables kept before the memo starts afresh.
    """

    def __init__(self, field: HeightField, reference_altitude_m: float, target_height_m: float = 0.0,
                 bins: int = 128, lattice_cells: int = 2, reach_m: float = 600.0, max_nodes: int = 50_000) -> None:
        if not reference_altitude_m > target_height_m:
            raise ValueError("reference_altitude_m must be above target_height_m")
        if int(bins) != bins or bins < 8:
            raise ValueError(f"bins must be an integer >= 8, got {bins!r}")
        if int(lattice_cells) != lattice_cells or lattice_cells < 1:
            raise ValueError(f"lattice_cells must be an integer >= 1, got {lattice_cells!r}")
        self.field, self.bins, self.max_nodes, self.reach_m = field, int(bins), int(max_nodes), float(reach_m)
        self.reference_altitude_m, self.target_height_m = float(reference_altitude_m), float(target_height_m)
        self.lattice_m = field.cell_m * int(lattice_cells)
        cell = field.cell_m
        near = np.arange(0.5 * cell, min(_NEAR_M, reach_m), cell)
        far = np.arange(near[-1] + 2.0 * cell, reach_m, 2.0 * cell) if reach_m > _NEAR_M else np.zeros(0)
        distances = np.concatenate([near, far])
        theta = -np.pi + (np.arange(self.bins) + 0.5) * (2.0 * np.pi / self.bins)
        # Samples along each azimuth as cell offsets from a node (nodes sit on cell corners).
        di = np.floor(np.cos(theta)[:, None] * distances / cell).astype(np.intp)
        dj = np.floor(np.sin(theta)[:, None] * distances / cell).astype(np.intp)
        pad = int(np.abs(np.concatenate([di.ravel(), dj.ravel()])).max()) + 1
        self._lattice_cells = int(lattice_cells)
        # Nodes cover the grid and ``margin`` cells of open ground around it (a whole number of lattice steps, so
        # that the nodes sit where they would without it); farther out no roof is within reach: open sky.
        self._margin = -(-pad // self._lattice_cells) * self._lattice_cells
        self._pad = pad + self._margin
        self._padded = np.pad(field.heights - np.float32(target_height_m), self._pad).clip(
            0.0, self.reference_altitude_m - self.target_height_m).astype(np.float32)
        self._flat = self._padded.ravel()
        self._offsets = di * self._padded.shape[1] + dj  # (bins, K) flat offsets
        self._inverse_distance = (1.0 / distances).astype(np.float32)
        rows, cols = field.heights.shape
        self._lattice_shape = ((rows + 2 * self._margin) // self._lattice_cells + 1,
                               (cols + 2 * self._margin) // self._lattice_cells + 1)
        self._row_of = np.full(self._lattice_shape[0] * self._lattice_shape[1], -1, dtype=np.intp)
        self._store = np.zeros((0, self.bins), dtype=np.float32)

    @property
    def nodes(self) -> int:
        """Tables computed and kept."""
        return len(self._store)

    def inverse_slopes(self, xy: ArrayLike) -> NDArray[np.float32]:
        """``1 / g(theta)`` (N, bins) at the nearest lattice node of each point (N, 2), 1/m scale."""
        points = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        edge = self._margin * self.field.cell_m
        ox, oy = self.field.origin_xy[0] - edge, self.field.origin_xy[1] - edge
        a = np.rint((points[:, 0] - ox) / self.lattice_m).astype(np.intp)
        b = np.rint((points[:, 1] - oy) / self.lattice_m).astype(np.intp)
        covered = (a >= 0) & (a < self._lattice_shape[0]) & (b >= 0) & (b < self._lattice_shape[1])
        if not covered.all():  # beyond the nodes no roof is within reach: open sky
            out = np.zeros((len(points), self.bins), dtype=np.float32)
            out[covered] = self.inverse_slopes(points[covered]) if covered.any() else out[covered]
            return out
        nodes = a * self._lattice_shape[1] + b
        rows = self._row_of[nodes]
        missing = np.unique(nodes[rows < 0])
        if len(missing):
            if len(self._store) + len(missing) > self.max_nodes:
                self._row_of[:] = -1
                self._store = self._store[:0]
                missing = np.unique(nodes)
            step, cols = self._lattice_cells, self._padded.shape[1]
            start = self._pad - self._margin  # the padded index of the first node
            keys = (start + (missing // self._lattice_shape[1]) * step) * cols \
                + start + (missing % self._lattice_shape[1]) * step
            tables = np.concatenate([self._compute(keys[c:c + _CHUNK_NODES]) for c in range(0, len(keys), _CHUNK_NODES)])
            self._row_of[missing] = np.arange(len(self._store), len(self._store) + len(missing))
            self._store = np.concatenate([self._store, tables])
            rows = self._row_of[nodes]
        stored: NDArray[np.float32] = self._store[rows]
        return stored

    def _compute(self, keys: NDArray[np.intp]) -> NDArray[np.float32]:
        """Tables of nodes given by flat keys into the padded field: max of ``(H - z_t) / s`` per azimuth."""
        rise = self._flat[keys[:, None, None] + self._offsets]  # (n, bins, K)
        rise *= self._inverse_distance
        tables: NDArray[np.float32] = rise.max(axis=-1)
        return tables

    def bin_of(self, dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.intp]:
        """The azimuth bin of horizontal offsets (dx, dy) from a target point to a vehicle."""
        k = (np.arctan2(dy, dx) + np.pi) * (self.bins / (2.0 * np.pi))
        return np.minimum(k.astype(np.intp), self.bins - 1)
