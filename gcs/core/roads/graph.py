"""A road network as numpy arrays: nodes, directed straight edges, successors and branch probabilities.

Frame: the scenario's local ENU metres. A road is a chain of straight
**segments** between **nodes** (junctions, dead ends and the shape points of a
bent road). Every two-way segment gives two **directed edges**, one per driving
direction; a one-way segment gives one. An edge ``e`` runs from
``nodes[tail[e]]`` to ``nodes[head[e]]``, its length is ``length[e]`` and its
unit direction ``direction[e]``; the point at arc length ``s`` along it is

.. math::
    p(e, s) = n_{tail(e)} + s \\, d_e, \\qquad 0 \\le s \\le \\ell_e .

**Successors.** A vehicle at the end of edge ``e`` drives on along one of the
edges leaving ``head[e]``, except the reverse of ``e`` (no U-turn), unless there
is no other way out (a dead end). ``successors[e, :]`` lists them, padded with
-1, and ``turn_cos[e, k]`` is the cosine of the angle turned onto each (1 straight
on, 0 a right-angle turn). :meth:`RoadGraph.branch_probabilities` turns those
into the row-stochastic transition table ``T[e, k] = P(next = successors[e, k] |
end of e)`` the trackers branch with (the junction split of Ulmke and Koch 2006; the turn
probabilities of the variable-structure IMM of Kirubarajan et al. 2000).

Building: :meth:`RoadGraph.from_segments` merges end points closer than a
tolerance into one node; :mod:`gcs.core.roads.sources` builds the segments of a
generated city's street grid or of GeoJSON LineStrings. Nearest-edge queries go
through :class:`gcs.core.roads.index.EdgeIndex`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["RoadGraph", "STRAIGHT_COS"]

STRAIGHT_COS = 0.9
"""A successor whose turn angle has a cosine above this (about 26 degrees) counts as straight on."""


if TYPE_CHECKING:
    from gcs.core.roads.index import EdgeIndex


def _frozen(*arrays: NDArray[np.generic]) -> None:
    for array in arrays:
        array.flags.writeable = False


@dataclass(frozen=True, eq=False)
class RoadGraph:
    """Nodes (N, 2), directed edges (E,) and their successors; read-only arrays (module docstring).

    Attributes
    ----------
    nodes : ndarray, shape (N, 2)
    tail, head : ndarray of int, shape (E,)
        Node index where each directed edge starts and ends.
    length : ndarray, shape (E,)
        Metres, > 0.
    direction : ndarray, shape (E, 2)
        Unit vector from tail to head.
    reverse : ndarray of int, shape (E,)
        The edge driving the same segment the other way, -1 for a one-way segment.
    successors : ndarray of int, shape (E, K)
        Edges a vehicle may take at the end of each edge, padded with -1; never empty.
    turn_cos : ndarray, shape (E, K)
        Cosine of the turn onto each successor (NaN on padding).
    """

    nodes: NDArray[np.float64]
    tail: NDArray[np.intp]
    head: NDArray[np.intp]
    length: NDArray[np.float64]
    direction: NDArray[np.float64]
    reverse: NDArray[np.intp]
    successors: NDArray[np.intp]
    turn_cos: NDArray[np.float64]
    _tables: dict[tuple[str, float], NDArray[np.float64]] = field(default_factory=dict, init=False, repr=False)

    @classmethod
    def from_segments(cls, a_xy: ArrayLike, b_xy: ArrayLike, one_way: ArrayLike | None = None,
                      merge_m: float = 0.5) -> RoadGraph:
        """The graph of straight segments ``a[i] -> b[i]`` (S, 2) each, ENU metres.

        End points closer than ``merge_m`` become one node (a junction), so roads
        meet where their coordinates agree to that tolerance. ``one_way[i]`` True
        makes segment ``i`` drivable from ``a`` to ``b`` only (default: two-way).
        Segments shorter than ``merge_m`` are dropped; a repeated segment is kept once.

        Raises
        ------
        ValueError
            For shapes that do not match, coordinates that are not finite, or no segment left.
        """
        a = np.asarray(a_xy, dtype=np.float64).reshape(-1, 2)
        b = np.asarray(b_xy, dtype=np.float64).reshape(-1, 2)
        if a.shape != b.shape:
            raise ValueError(f"segment starts {a.shape} and ends {b.shape} differ in shape")
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            raise ValueError("road coordinates must be finite")
        oneway = np.zeros(len(a), dtype=bool) if one_way is None else np.asarray(one_way, dtype=bool).reshape(-1)
        if oneway.shape != (len(a),):
            raise ValueError(f"one_way must give one flag per segment ({len(a)}), got {oneway.shape}")
        if not merge_m > 0.0:
            raise ValueError(f"merge_m must be > 0, got {merge_m!r}")
        keys = np.round(np.concatenate([a, b]) / merge_m).astype(np.int64)
        unique_keys, node_of = np.unique(keys, axis=0, return_inverse=True)
        node_of = node_of.reshape(-1)
        nodes = np.zeros((len(unique_keys), 2))
        np.add.at(nodes, node_of, np.concatenate([a, b]))
        nodes /= np.bincount(node_of, minlength=len(unique_keys))[:, None]
        u, v = node_of[: len(a)], node_of[len(a):]
        keep = u != v
        # One segment per unordered node pair and drivable direction.
        pairs = np.stack([np.minimum(u, v), np.maximum(u, v), np.where(oneway, np.where(u < v, 1, 2), 0)], axis=1)
        _, first = np.unique(pairs[keep], axis=0, return_index=True)
        chosen = np.flatnonzero(keep)[np.sort(first)]
        if len(chosen) == 0:
            raise ValueError(f"no road segment is longer than merge_m = {merge_m} m")
        u, v, oneway = u[chosen], v[chosen], oneway[chosen]
        two = ~oneway
        tail = np.concatenate([u, v[two]])
        head = np.concatenate([v, u[two]])
        forward = np.arange(len(u))
        reverse = np.full(len(tail), -1, dtype=np.intp)
        backward = len(u) + np.arange(int(two.sum()))
        reverse[forward[two]] = backward
        reverse[backward] = forward[two]
        return cls._build(nodes, tail.astype(np.intp), head.astype(np.intp), reverse)

    @classmethod
    def _build(cls, nodes: NDArray[np.float64], tail: NDArray[np.intp], head: NDArray[np.intp],
               reverse: NDArray[np.intp]) -> RoadGraph:
        delta = nodes[head] - nodes[tail]
        length = np.hypot(delta[:, 0], delta[:, 1])
        direction = delta / length[:, None]
        order = np.argsort(tail, kind="stable")
        starts = np.searchsorted(tail[order], np.arange(len(nodes) + 1))
        out_degree = np.diff(starts)
        width = max(int(out_degree.max()), 1)
        successors = np.full((len(tail), width), -1, dtype=np.intp)
        for e in range(len(tail)):
            leaving = order[starts[head[e]]:starts[head[e] + 1]]
            onward = leaving[leaving != reverse[e]]
            if onward.size == 0:  # a dead end: turn back (or stop, on a one-way road that ends)
                onward = leaving if leaving.size else np.array([reverse[e] if reverse[e] >= 0 else e])
            successors[e, :onward.size] = onward
        valid = successors >= 0
        turn_cos = np.where(valid, np.einsum("ea,eka->ek", direction, direction[np.where(valid, successors, 0)]),
                            np.nan)
        _frozen(nodes, tail, head, length, direction, reverse, successors, turn_cos)
        return cls(nodes, tail, head, length, direction, reverse, successors, turn_cos)

    def __len__(self) -> int:
        """Number of directed edges."""
        return len(self.length)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``xmin, ymin, xmax, ymax`` of the nodes, metres."""
        lo, hi = self.nodes.min(axis=0), self.nodes.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def total_length_m(self) -> float:
        """Length of road, each two-way segment counted once, metres."""
        return float(self.length[(self.reverse < 0) | (self.reverse > np.arange(len(self)))].sum())

    def position(self, edge: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """ENU points (..., 2) at arc length ``s`` (...) along ``edge`` (...), ``p = n_tail + s d``."""
        e = np.asarray(edge, dtype=np.intp)
        return self.nodes[self.tail[e]] + np.asarray(s, dtype=np.float64)[..., None] * self.direction[e]

    def branch_probabilities(self, turn_probability: float) -> NDArray[np.float64]:
        """Row-stochastic ``T (E, K)``: ``T[e, k] = P(next edge = successors[e, k] | at the end of e)``.

        Where a successor goes straight on (``turn_cos > STRAIGHT_COS``) it gets
        ``1 - turn_probability`` and the turns share ``turn_probability`` equally;
        elsewhere (a T-junction met from its stem, a bend, a dead end) every way on
        is equally likely. Zero on padding. Cached per value.
        """
        if not 0.0 <= turn_probability <= 1.0:
            raise ValueError(f"turn_probability must be in [0, 1], got {turn_probability!r}")
        key = ("branch", float(turn_probability))
        table = self._tables.get(key)
        if table is None:
            valid = self.successors >= 0
            straight = valid & (self.turn_cos > STRAIGHT_COS)
            has_straight = straight.any(axis=1, keepdims=True)
            turns = (valid & ~straight).sum(axis=1, keepdims=True)
            count = valid.sum(axis=1, keepdims=True)
            uniform = valid / count
            with np.errstate(invalid="ignore", divide="ignore"):
                straight_count = np.maximum(straight.sum(1, keepdims=True), 1)
                share_straight = np.where(turns > 0, 1.0 - turn_probability, 1.0) / straight_count
                share_turn = turn_probability / np.maximum(turns, 1)
            biased = np.where(straight, share_straight, np.where(valid, share_turn, 0.0))
            table = np.where(has_straight, biased, uniform)
            table /= table.sum(axis=1, keepdims=True)
            _frozen(table)
            self._tables[key] = table
        return table

    @cached_property
    def index(self) -> EdgeIndex:
        """The :class:`~gcs.core.roads.index.EdgeIndex` of this graph (built on first use)."""
        from gcs.core.roads.index import EdgeIndex

        return EdgeIndex.build(self)

    def snap(self, points: ArrayLike, within_m: float | None = None
             ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """Nearest edge of each point (..., 2): ``(edge, s, distance_m)``; see :meth:`EdgeIndex.nearest`."""
        return self.index.nearest(points, within_m)
