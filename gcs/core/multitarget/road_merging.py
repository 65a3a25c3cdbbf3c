"""Unresolved road tracks: two tracks on one car, or on two cars closer than the sensors resolve, become one.

Two cars side by side in the lanes of one street, or one close behind the
other, give detections that no association can tell apart: two tracks on them
take the detections in turn and their labels are arbitrary, so a track set
that keeps both reports identities it does not have. Such tracks are
**unresolved** (Blackman and Popoli 1999, the merging of tracks that share
their observations; Koch and van Keuk 1997, possibly unresolved measurements),
and the tracker keeps one of them: the older, which carries the longer history.

Tracks ``a`` and ``b`` (their summaries ``x``, ``P``; their clouds' weights per
directed edge ``w_a(e)``) are unresolved on a scan when

* they drive the same streets the same way: ``sum_e min(w_a(e), w_b(e)) >= o_min``
  (crossing cars, or cars meeting head-on, are on different directed edges);
* their positions agree as one target's two estimates would (Bar-Shalom 1981, the
  test of common origin without the cross-covariance):
  ``(x_a - x_b)^T (P_a + P_b)^{-1} (x_a - x_b) <= gamma``, position block, 2 dof.

A track unresolved from an older confirmed track on ``merge_scans`` consecutive
scans is dropped (a car that merely passes another, or two cars that part,
are unresolved for a few scans only).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.multitarget.road_clouds import TrackClouds
from gcs.core.multitarget.tracks import Lifecycle, TrackSet

__all__ = ["edge_weights", "unresolved", "merged"]


def edge_weights(clouds: TrackClouds, edges: int) -> NDArray[np.float64]:
    """Each track's road weight per directed edge (T, E); off-road particles count on no edge."""
    t, p = clouds.tracks, clouds.per_track
    cloud = clouds.cloud
    rows = np.repeat(np.arange(t), p)
    weight = np.where(cloud.on_road, np.exp(cloud.log_weight), 0.0)
    totals = np.bincount(rows * edges + cloud.edge, weights=weight, minlength=t * edges)
    return np.asarray(totals, dtype=np.float64).reshape(t, edges)


def unresolved(clouds: TrackClouds, mean: NDArray[np.float64], cov: NDArray[np.float64], edges: int,
               overlap_min: float, threshold: float) -> NDArray[np.bool_]:
    """(T, T), symmetric, False on the diagonal: which pairs of tracks are unresolved on this scan (module docstring)."""
    t = clouds.tracks
    if t < 2:
        return np.zeros((t, t), dtype=bool)
    weights = edge_weights(clouds, edges)
    overlap = np.minimum(weights[:, None, :], weights[None, :, :]).sum(axis=2)
    diff = mean[:, None, :2] - mean[None, :, :2]
    total = cov[:, None, :2, :2] + cov[None, :, :2, :2]
    d2 = np.einsum("abi,abi->ab", diff, np.linalg.solve(total, diff[..., None])[..., 0])
    pairs: NDArray[np.bool_] = (overlap >= overlap_min) & (d2 <= threshold)
    np.fill_diagonal(pairs, False)
    return pairs


def merged(tracks: TrackSet, pairs: NDArray[np.bool_], unresolved_scans: NDArray[np.int64], merge_scans: int
           ) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
    """The tracks to drop (T,) and every track's new count of consecutive unresolved scans (T,).

    Track ``b`` counts a scan when some confirmed track with a smaller id (older) is
    unresolved from it (``pairs``, :func:`unresolved`)."""
    older = tracks.ids[:, None] < tracks.ids[None, :]  # [a, b]: a is older than b
    confirmed = tracks.status == Lifecycle.CONFIRMED
    shadowed = (pairs & older & confirmed[:, None]).any(axis=0)
    counts = np.where(shadowed, unresolved_scans + 1, 0)
    return counts >= merge_scans, counts
