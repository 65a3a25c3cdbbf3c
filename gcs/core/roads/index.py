"""Nearest road edge of many points at once: a uniform grid of cells, each listing the edges near it.

Each cell of side ``c`` lists every edge whose bounding box, grown by ``c``,
overlaps the cell; so every edge within ``c`` of a point in the cell is in the
cell's list, and the nearest edge of a point closer than ``c`` to the road is
found among that list alone. A point farther than ``c`` from every listed edge
falls back to testing every edge. The distance from ``q`` to edge ``e`` is that
to its closest point ``p(e, s*)`` with ``s* = clip(d_e . (q - n_tail), 0, l_e)``.

Of the two directed edges of a two-way segment (the same points), the one with
the lower index is returned.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from gcs.core.roads.graph import RoadGraph

__all__ = ["EdgeIndex"]


def _project(graph: RoadGraph, edges: NDArray[np.intp],
             q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Arc length of the closest point of each edge (..., K) to each point (..., 2) and the squared distance."""
    start = graph.nodes[graph.tail[edges]]
    d = graph.direction[edges]
    rel = q[..., None, :] - start
    s = np.clip(np.einsum("...ka,...ka->...k", rel, d), 0.0, graph.length[edges])
    gap = rel - s[..., None] * d
    return s, np.einsum("...ka,...ka->...k", gap, gap)


@dataclass(frozen=True, eq=False)
class EdgeIndex:
    """Cells of side ``cell_m`` from ``origin``: ``cells[i, j]`` lists edges (padded with -1)."""

    graph: RoadGraph
    origin: NDArray[np.float64]
    cell_m: float
    shape: tuple[int, int]
    cells: NDArray[np.intp]

    @classmethod
    def build(cls, graph: RoadGraph, cell_m: float | None = None) -> EdgeIndex:
        """Index ``graph``'s edges (one of each two-way pair); ``cell_m`` defaults to the median edge length."""
        forward = np.flatnonzero((graph.reverse < 0) | (graph.reverse > np.arange(len(graph))))
        if cell_m is None:
            cell_m = float(np.clip(np.median(graph.length[forward]), 10.0, 200.0))
        a, b = graph.nodes[graph.tail[forward]], graph.nodes[graph.head[forward]]
        lo = np.minimum(a, b) - cell_m
        hi = np.maximum(a, b) + cell_m
        origin = graph.nodes.min(axis=0) - cell_m
        nx, ny = (np.floor((graph.nodes.max(axis=0) + cell_m - origin) / cell_m).astype(int) + 1).tolist()
        i0, j0 = np.floor((lo - origin) / cell_m).astype(int).T
        i1, j1 = np.floor((hi - origin) / cell_m).astype(int).T
        lists: list[list[int]] = [[] for _ in range(nx * ny)]
        for e, x0, x1, y0, y1 in zip(forward.tolist(), i0.tolist(), i1.tolist(), j0.tolist(), j1.tolist()):
            for i in range(max(x0, 0), min(x1, nx - 1) + 1):
                for j in range(max(y0, 0), min(y1, ny - 1) + 1):
                    lists[i * ny + j].append(e)
        width = max(1, max(len(cell) for cell in lists))
        cells = np.full((nx * ny, width), -1, dtype=np.intp)
        for k, cell in enumerate(lists):
            cells[k, :len(cell)] = cell
        cells.flags.writeable = False
        return cls(graph, origin, float(cell_m), (nx, ny), cells)

    def nearest(self, points: ArrayLike, within_m: float | None = None
                ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """``(edge, s, distance_m)`` of the nearest edge of each point (..., 2) (module docstring).

        ``within_m`` (at most the cell size): only edges that near are of interest, so a
        point farther than the cells reach is not tested against every edge; its
        distance is ``inf`` (its edge and ``s`` mean nothing)."""
        q = np.asarray(points, dtype=np.float64)
        shape = q.shape[:-1]
        flat = q.reshape(-1, 2)
        ij = np.floor((flat - self.origin) / self.cell_m).astype(np.intp)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.shape[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < self.shape[1])
        candidates = self.cells[np.where(inside, ij[:, 0] * self.shape[1] + ij[:, 1], 0)]
        candidates = np.where(inside[:, None], candidates, -1)
        valid = candidates >= 0
        s, d2 = _project(self.graph, np.where(valid, candidates, 0), flat)
        d2 = np.where(valid, d2, np.inf)
        best = np.argmin(d2, axis=1)
        rows = np.arange(len(flat))
        edge, arc, dist2 = candidates[rows, best], s[rows, best], d2[rows, best]
        far = ~(dist2 <= self.cell_m**2)
        if within_m is not None and within_m <= self.cell_m:
            dist2[far] = np.inf
            far[:] = False
        if far.any():  # beyond the cells' reach: test every edge
            every = np.arange(len(self.graph))
            s_all, d2_all = _project(self.graph, np.broadcast_to(every, (int(far.sum()), len(every))), flat[far])
            pick = np.argmin(d2_all, axis=1)
            chosen = every[pick]
            twin = self.graph.reverse[chosen]
            lower = (twin >= 0) & (twin < chosen)
            rows_far = np.arange(len(pick))
            s_far = s_all[rows_far, pick]
            edge[far] = np.where(lower, twin, chosen)
            arc[far] = np.where(lower, self.graph.length[chosen] - s_far, s_far)
            dist2[far] = d2_all[rows_far, pick]
        return edge.reshape(shape), arc.reshape(shape), np.sqrt(dist2).reshape(shape)
